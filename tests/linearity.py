"""How a parser's time grows with its input: the ratio of CPU times at n and 2n, for the linear-time tests.

CPU time of this process (`time.process_time`), the least of a few runs: the other engineers' and workers' load
on the two shared cores then moves the ratio little, where wall times moved it by 2x. Linear work doubles (1.0-2.2
here, with the constant parts); quadratic work quadruples."""

from __future__ import annotations

import time
from collections.abc import Callable

LINEAR_RATIO = 2.2
"""Time at 2n over time at n, at most, for a parser linear in its input."""


def cpu_seconds(run: Callable[[], object], repeats: int = 3) -> float:
    best = float("inf")
    for _ in range(repeats):
        start = time.process_time()
        run()
        best = min(best, time.process_time() - start)
    return best


def doubling_ratio(run: Callable[[int], object], n: int, repeats: int = 3) -> float:
    """cpu(2n) / cpu(n) for `run(size)`; `n` should make cpu(n) at least ~20 ms, above the clock's noise."""
    run(n)  # imports, caches, first-call costs: out of the measure
    return cpu_seconds(lambda: run(2 * n), repeats) / cpu_seconds(lambda: run(n), repeats)
