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
from dataclasses import dataclass


class Cancelled(Exception):
    """The computation was stopped because its token was set; nothing it produced is a result."""


DEADLINE = "deadline"
"""The reason a server sets when a computation runs past its deadline (`cancel(DEADLINE)`), as opposed to a
client that left or a job that was cancelled: a structure's first build is not the computation's own time
(`exempt_builds`)."""


class CancellationToken:
    """Set once (`cancel()`, or the `probe` answering True), read cheaply and often (`cancelled`, `check()`).
    `reason` is the first `cancel`'s."""

    def __init__(self, probe: Callable[[], bool] | None = None, on_step: Callable[[Step], None] | None = None) -> None:
        self._event = threading.Event()
        self._probe = probe
        self.reason: str | None = None
        self.on_step = on_step
        """Told of every solver iteration (`step`): what a job reports as its progress. It must not raise."""

    def cancel(self, reason: str = "stop") -> None:
        if self.reason is None:
            self.reason = reason
        self._event.set()

    @property
    def cancelled(self) -> bool:
        return self._event.is_set() or (self._probe is not None and self._probe())

    def check(self) -> None:
        if self.cancelled:
            raise Cancelled("the computation was cancelled")


@dataclass(frozen=True)
class Step:
    """One iteration of a solve: its number, how many such solves have taken (None: none seen yet), and the
    time the solve has run."""

    iteration: int
    expected: int | None
    seconds: float

    @property
    def eta_seconds(self) -> float | None:
        """The time left if this solve takes as many iterations as such solves have (at least one more)."""
        if self.expected is None or self.iteration <= 0:
            return None
        remaining = max(self.expected - self.iteration, 1)
        return remaining * self.seconds / self.iteration


def step(progress: Step) -> bool:
    """A solver iteration passed: tell the current token's `on_step`; whether the computation was cancelled."""
    token = _current.get()
    if token is None:
        return False
    if token.on_step is not None:
        token.on_step(progress)
    return token.cancelled


_builds = [0]
"""Structure builds started in this process (`models.engine.runtime`: a structure's Functions, native libraries,
solvers,
tables), and how many run now."""
_building = [0]
_build_lock = threading.Lock()
_build_listeners: list[Callable[[int, int], None]] = []


def on_builds(listener: Callable[[int, int], None]) -> None:
    """Tell `listener(started, running)` of every build's start and end in this process: a server's compute
    process publishes them to its parent, whose watchdog must not end a computation that pays a build (the
    exemption `exempt_builds` makes for the deadline). `listener` must not raise."""
    _build_listeners.append(listener)


def _told() -> None:
    with _build_lock:
        counts = (_builds[0], _building[0])
    for listener in _build_listeners:
        listener(*counts)


@contextmanager
def structure_build() -> Iterator[None]:
    """Mark a structure's first-use build (what every later request of that structure finds ready)."""
    with _build_lock:
        _builds[0] += 1
        _building[0] += 1
    _told()
    try:
        yield
    finally:
        with _build_lock:
            _building[0] -= 1
        _told()


def builds_since(count: int) -> bool:
    """Whether a structure build started since `builds_started()` said `count`, or one runs now."""
    with _build_lock:
        return _builds[0] != count or _building[0] > 0


def builds_started() -> int:
    with _build_lock:
        return _builds[0]


def exempt_builds(passed: Callable[[], str | None]) -> CancellationToken:
    """A token that stops when `passed()` (the reason the caller set) is a stop, or a deadline that passed during
    a computation that built no structure: a structure's first build (a compile of seconds) is not work the
    deadline meant to bound, so the request that happens to pay it runs to its end. The count is the process's:
    in a compute process that is the one computation; among threads, a build by another also exempts this one."""
    start = builds_started()

    def stopped() -> bool:
        reason = passed()
        return reason is not None and (reason != DEADLINE or not builds_since(start))

    return CancellationToken(probe=stopped)


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
