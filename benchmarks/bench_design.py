"""Pose design: K = 30 of M = 2 000 and M = 20 000 for every criterion, and the target mode.

"condition" is the default condition design (D-efficiency floor 0.9), "condition(no floor)" the plain criterion.
Each design runs in a fresh process (its peak memory is its own) after a warm-up design that loads the compiled
Functions. Efficiency is against the design's own certified bound; the TCP error ratio is the design's predicted
RMS TCP error after calibration over the median of 20 random selections of the same size from the same candidates,
both from the same run.
"""

from __future__ import annotations

import json
import subprocess
import sys

from benchmarks.timing import markdown_table, target

CRITERIA = ("D", "A", "E", "I", "condition")
BOUND_SECONDS = (3.0, 20.0)
"""Budgets of the opt-in branch and bound on the D certificate (Newton leaves, 15-35 ms a leaf loaded: 0.985 is
reached after ~120 leaves, ~2 s; 3 s leaves a margin for load)."""

_RUN = """
import json, resource, time
from models import iwr
from optimal_design import design_poses
desc = iwr()
design_poses(desc, 30, "D", candidate_count=200, seed=9)  # warm caches (Functions, structural subset)
t = time.perf_counter()
d = design_poses(desc, 30, {criterion!r}, candidate_count={m}, seed=1{extra})
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
    "rms_ratio_to_random": d.metrics["predicted_rms_tcp_mm"] / d.random_baseline["predicted_rms_tcp_mm"],
    "condition_number": d.metrics["condition_number"],
    "random_condition_number": d.random_baseline["condition_number"],
    "log_det": d.metrics["log_det"],
    "notes": list(d.notes),
    "branch_and_bound": d.bound and d.bound.get("branch_and_bound"),
}}))
"""

_TARGET = """
import json, resource, time
from models import iwr
from optimal_design import design_for_target, design_poses
desc = iwr()
design_poses(desc, 30, "D", candidate_count=200, seed=9)
t = time.perf_counter()
from models import sample_workspace
fixed = sample_workspace(desc, {fixed}, seed=5) if {fixed} else None
r = design_for_target(desc, rms_tcp_mm={goal!r}, fixed=fixed, candidate_count=2000, seed=1)
wall = time.perf_counter() - t
print(json.dumps({{
    "wall_s": wall,
    "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    "count": r.count,
    "designs": len(r.curve),
    "curve": list(r.curve),
}}))
"""


def _run(code: str) -> dict[str, object]:
    """One measurement in a fresh process, so its peak memory is its own."""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    result: dict[str, object] = json.loads(out.stdout.strip().splitlines()[-1])
    return result


def _measure(criterion: str, m: int, extra: str = "") -> dict[str, object]:
    return _run(_RUN.format(criterion=criterion, m=m, extra=extra))


def _table(results: dict[str, dict[str, object]]) -> list[str]:
    """The markdown table of every criterion at both sizes."""
    header = ["criterion", "M", "wall (s)", "peak memory (MB)", "efficiency", "greedy efficiency",
              "TCP error / random", "condition / random"]  # fmt: skip
    rows = []
    for key, r in results.items():
        criterion, m = key.split("_M")
        geff = r["greedy_efficiency"]
        rows.append(
            [
                criterion,
                m.split("_")[0],
                f"{float(r['wall_s']):.2f}",  # type: ignore[arg-type]
                f"{float(r['peak_rss_mb']):.0f}",  # type: ignore[arg-type]
                f"{float(r['efficiency']):.4f}",  # type: ignore[arg-type]
                f"{float(geff) if geff is not None else float('nan'):.4f}",  # type: ignore[arg-type]
                f"{float(r['rms_ratio_to_random']):.3f}",  # type: ignore[arg-type]
                f"{float(r['condition_number']) / float(r['random_condition_number']):.3f}",  # type: ignore[arg-type]
            ]
        )
    return markdown_table(header, rows)


def run() -> dict[str, object]:
    out: dict[str, object] = {}
    targets = []
    designs: dict[str, dict[str, object]] = {}
    for m in (2000, 20_000):
        for criterion in CRITERIA:
            res = _measure(criterion, m)
            designs[f"{criterion}_M{m}_K30"] = res
            wall, mem = float(res["wall_s"]), float(res["peak_rss_mb"])  # type: ignore[arg-type]
            if m == 2000:
                targets.append(target(f"{criterion}: K=30 of M=2000, wall (s)", wall, 1.0 if criterion == "D" else 5.0))
            elif criterion == "D":
                targets.append(target("D: K=30 of M=20000, wall (s)", wall, 10.0))
            targets.append(target(f"{criterion}: M={m} peak memory (MB)", mem, 1024.0))
            certified = float(bool(res["certified"]))
            targets.append(target(f"{criterion}: M={m} bound certified (1 = yes)", certified, 1.0, ">="))
    # "condition" is the default, kept at D-efficiency >= 0.9; the plain criterion (floor 0) is the one whose
    # efficiency against its own bound the issue asks about.
    for m in (2000, 20_000):
        designs[f"condition(no floor)_M{m}_K30"] = _measure("condition", m, ", d_efficiency_floor=0")
    # The D certificate tightened by branch and bound (opt-in): how much of the gap is the relaxation's.
    tightened = {}
    for seconds in BOUND_SECONDS:
        tightened[seconds] = _measure("D", 2000, f", bound_seconds={seconds}")
        designs[f"D(+{seconds:g} s branch and bound)_M2000_K30"] = tightened[seconds]
    out.update(designs)
    d = designs["D_M2000_K30"]
    targets.append(target("D: efficiency against the certified bound", float(d["efficiency"]), 0.985, ">="))  # type: ignore[arg-type]
    for seconds, result in tightened.items():
        targets.append(
            target(
                f"D: efficiency against the bound after {seconds:g} s of branch and bound",
                float(result["efficiency"]),  # type: ignore[arg-type]
                0.985,
                ">=",
            )
        )
    for m in (2000, 20_000):
        for criterion in ("E", "condition(no floor)"):
            eff = float(designs[f"{criterion}_M{m}_K30"]["efficiency"])  # type: ignore[arg-type]
            targets.append(target(f"{criterion}: M={m} efficiency against the certified bound", eff, 0.9, ">="))
    for criterion in (*CRITERIA, "condition(no floor)"):
        ratio = float(designs[f"{criterion}_M2000_K30"]["rms_ratio_to_random"])  # type: ignore[arg-type]
        limit = 0.7 if criterion in ("condition", "D", "I") else 1.0
        targets.append(target(f"{criterion}: predicted TCP error / random, M=2000", ratio, limit))
    for goal, fixed in ((0.03, 0), (0.02, 0), (0.02, 20)):
        res = _run(_TARGET.format(goal=goal, fixed=fixed))
        name = f"target {goal} mm" + (f" after {fixed} measured" if fixed else "")
        out[name] = res
        targets.append(target(f"{name} (I, M=2000): wall (s)", float(res["wall_s"]), 30.0))  # type: ignore[arg-type]
    out["markdown"] = _table(designs)
    out["targets"] = targets
    return out
