"""Small dense linear algebra runs fastest on one BLAS thread.

The matrices of a calibration are a few hundred rows by at most 70 columns.
On them OpenBLAS's threads cost more in synchronisation than they gain: a
pivoted QR of 360 × 70 took 45 ms with two threads and 1 ms with one on the
2-core reference machine. Code paths made of such calls run under this limit.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from threadpoolctl import ThreadpoolController

P = ParamSpec("P")
R = TypeVar("R")


def single_threaded_blas(fn: Callable[P, R]) -> Callable[P, R]:
    """Run `fn` with BLAS limited to one thread (restored afterwards)."""

    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        with _controller().limit(limits=1, user_api="blas"):
            return fn(*args, **kwargs)

    return wrapper


@functools.cache
def _controller() -> ThreadpoolController:
    """One controller, made at the first call (every BLAS is loaded by then: models imports numpy and
    scipy.linalg): `threadpool_limits()` scans the process's libraries on every call, 6.6 ms of a 33 ms
    calibration of a 7R arm, measured."""
    return ThreadpoolController()
