"""Reading and rewriting a large program makes about a million small objects (tokens, numbers, slots), none of
them in a reference cycle. Python's cycle collector, triggered by allocations alone, traverses every live
object again each time the heap grows by a quarter: measured on a 10 000-target URScript program, making
the 320 000 tokens took 0.73 s with it and 0.14 s without. So the readers pause it while they allocate;
reference counting still frees everything, and the collector runs as usual afterwards."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def collector_paused() -> Iterator[None]:
    """The cycle collector off inside (and back on after, if it was on at entry: nested or concurrent uses
    leave it as the outermost found it, at the latest when that one ends)."""
    was_on = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_on:
            gc.enable()
