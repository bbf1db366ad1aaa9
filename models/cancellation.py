"""Cooperative cancellation of long computations: a token the caller sets, checked at natural steps.

The caller (a server whose client hung up, a job that was cancelled) holds a `CancellationToken` and installs
it for the computation with `cancellable(token)`; the identification solve (once per IPOPT iteration) and the
pose-design loops (once per step) call `check()`, which raises `Cancelled` once the token is set. A token is
either set in this process (`cancel()`, from another thread) or reads a flag another process sets (`probe`:
the service's compute processes read a byte of shared memory), so nothing here knows about either.

The current token is a context variable, not a parameter: the solve and the design loops are many calls deep,
and a context variable follows the computation into the thread or process-pool task that runs it.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar


class Cancelled(Exception):
    """The computation was stopped because its token was set; nothing it produced is a result."""


class CancellationToken:
    """Set once (`cancel()`, or the `probe` answering True), read cheaply and often (`cancelled`, `check()`)."""

    def __init__(self, probe: Callable[[], bool] | None = None) -> None:
        self._event = threading.Event()
        self._probe = probe

    def cancel(self) -> None:
        self._event.set()

    @property
    def cancelled(self) -> bool:
        return self._event.is_set() or (self._probe is not None and self._probe())

    def check(self) -> None:
        if self.cancelled:
            raise Cancelled("the computation was cancelled")


_current: ContextVar[CancellationToken | None] = ContextVar("cancellation_token", default=None)


@contextmanager
def cancellable(token: CancellationToken | None) -> Iterator[CancellationToken | None]:
    """Run the block with `token` as the current one (None: not cancellable)."""
    reset = _current.set(token)
    try:
        yield token
    finally:
        _current.reset(reset)


def current() -> CancellationToken | None:
    return _current.get()


def cancelled() -> bool:
    token = _current.get()
    return token is not None and token.cancelled


def check() -> None:
    """Raise `Cancelled` if the current computation's token is set (nothing when there is none)."""
    token = _current.get()
    if token is not None:
        token.check()
