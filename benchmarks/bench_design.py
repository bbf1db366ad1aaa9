"""Pose design: K = 30 from M = 2 000 for every criterion, M = 20 000 for D, against greedy + exchange."""

from __future__ import annotations

import json
import subprocess
import sys

from benchmarks.timing import target

_RUN = """
import json, resource, time
from models import iwr
from optimal_design import design_poses
desc = iwr()
design_poses(desc, 30, "D", candidate_count=200, seed=9)  # warm caches (Functions, structural subset)
t = time.perf_counter()
d = design_poses(desc, 30, {criterion!r}, candidate_count={m}, seed=1)
wall = time.perf_counter() - t
print(json.dumps({{
    "wall_s": wall,
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    "value": d.value,
    "bound": d.bound and d.bound["value"],
    "certified": d.bound is not None,
    "efficiency": d.efficiency,
    "greedy_value": d.greedy["value"],
    "greedy_efficiency": d.greedy["efficiency"],
    "greedy_seconds": d.greedy["seconds"],
    "relaxation": d.relaxation,
    "predicted_rms_tcp_mm": d.metrics["predicted_rms_tcp_mm"],
    "random_predicted_rms_tcp_mm": d.random_baseline["predicted_rms_tcp_mm"],
    "condition_number": d.metrics["condition_number"],
    "random_condition_number": d.random_baseline["condition_number"],
    "notes": list(d.notes),
}}))
"""


def _measure(criterion: str, m: int) -> dict[str, object]:
    """One design in a fresh process, so its peak memory is its own."""
    out = subprocess.run(
        [sys.executable, "-c", _RUN.format(criterion=criterion, m=m)], capture_output=True, text=True, check=True
    )
    result: dict[str, object] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def run() -> dict[str, object]:
    out: dict[str, object] = {}
    targets = []
    for criterion in ("D", "A", "E", "I", "condition"):
        res = _measure(criterion, 2000)
        out[f"{criterion}_M2000_K30"] = res
        limit = 20.0 if criterion == "D" else 60.0
        targets.append(target(f"{criterion}: K=30 of M=2000, wall (s)", float(res["wall_s"]), limit))  # type: ignore[arg-type]
        targets.append(target(f"{criterion}: bound certified (1 = yes)", float(bool(res["certified"])), 1.0, ">="))
        if criterion == "D":
            targets.append(target("D: peak memory (MB)", float(res["peak_rss_mb"]), 2048.0))  # type: ignore[arg-type]
            targets.append(target("D: efficiency against the certified bound", float(res["efficiency"]), 0.97, ">="))  # type: ignore[arg-type]
    big = _measure("D", 20_000)
    out["D_M20000_K30"] = big
    targets.append(target("D: K=30 of M=20000, wall (s)", float(big["wall_s"]), 120.0))  # type: ignore[arg-type]
    out["targets"] = targets
    return out
