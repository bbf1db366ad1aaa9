"""Small helpers shared by the benchmark modules."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any

Clock = Callable[[], float]
"""time.perf_counter (wall seconds) or time.process_time (this process's CPU seconds, every thread: what the
machine's other load does not inflate)."""


def _times(fn: Callable[[], Any], repeat: int, clock: Clock) -> list[float]:
    times = []
    for _ in range(repeat):
        started = clock()
        fn()
        times.append(clock() - started)
    return times


def best_of(fn: Callable[[], Any], repeat: int = 3, *, clock: Clock = time.perf_counter) -> float:
    """Fastest time of `repeat` calls, seconds on `clock`: the least disturbed by the rest of the machine."""
    return min(_times(fn, repeat, clock))


def median_of(fn: Callable[[], Any], repeat: int, *, clock: Clock = time.perf_counter) -> float:
    """Median time of `repeat` calls, seconds on `clock`."""
    return statistics.median(_times(fn, repeat, clock))


def markdown_table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> list[str]:
    """A markdown table's lines (docs/benchmarks.md): the `header` cells, the rule under them, a line per row."""

    def line(cells: Sequence[str]) -> str:
        return "| " + " | ".join(cells) + " |"

    return [line(header), "|" + "---|" * len(header), *(line(row) for row in rows)]


def target(name: str, value: float, limit: float, op: str = "<=") -> dict[str, object]:
    met = value <= limit if op == "<=" else value >= limit
    return {"name": name, "value": float(value), "limit": float(limit), "op": op, "met": bool(met)}


def aligned_fit_targets(
    label: str, medians: tuple[float, float, float], limits: tuple[float, float, float], seeds: int
) -> list[dict[str, object]]:
    """A reference benchmark's three targets on its fits' TCP errors after alignment (medians over `seeds`): over
    the Cramér–Rao bound, over the nominal model's, over the scipy + numpy reference estimator's."""
    over_bound, over_nominal, over_reference = medians
    return [
        target(
            f"{label}: TCP error after alignment / Cramér–Rao bound (median of {seeds} seeds)", over_bound, limits[0]
        ),
        target(f"{label}: TCP error / the nominal model's", over_nominal, limits[1]),
        target(f"{label}: TCP error / scipy + numpy reference estimator's", over_reference, limits[2]),
    ]
