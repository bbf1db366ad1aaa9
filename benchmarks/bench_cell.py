"""The cell (models.cell): feasibility cost per candidate, and pose design at K = 30, M = 2 000 with and without it.

Cells as in tests/optimal_design/test_cell_design.py: the UR5-like arm on a table with a fixture and a tracker
2.5 m away (a 60° reflector cone, position records), the IWR (tool 150 mm) with a table, a fixture and a tracker
(pose records). Design times, wall and CPU (the target is on CPU: the machine is shared), are best of 3 after a
warm-up design (the compiled Functions and the frames' Function built); the design with the cell samples until
2 000 candidates are feasible, so its time includes checking every refused one. The library's own cost is one
capsule-box distance (python-fcl).
"""

from __future__ import annotations

import time

import fcl  # type: ignore[import-untyped]
import numpy as np

from benchmarks.timing import best_of, target
from models.cell import Box, Cell, Obstacle, Tracker, cell_for, check_poses
from models.description.examples import ur5_like
from models.description.iwr import iwr
from models.description.robot import RobotDescription
from models.workspace import sample_workspace
from optimal_design import design_poses

K, M = 30, 2000
TIME_RATIO_LIMIT = 2.0


def _ur5() -> tuple[RobotDescription, Cell, str]:
    desc = ur5_like()
    table = Obstacle("table", Box(1500.0, 1500.0, 40.0), (0.0, 0.0, -21.0, 0.0, 0.0, 0.0))
    fixture = Obstacle("fixture", Box(300.0, 300.0, 300.0), (500.0, 300.0, 150.0, 0.0, 0.0, 0.2))
    tracker = Tracker((2500.0, 0.0, 600.0), acceptance=float(np.radians(60.0)))
    return desc, cell_for(desc, obstacles=(table, fixture), tracker=tracker), "position"


def _iwr() -> tuple[RobotDescription, Cell, str]:
    desc = iwr(tool=(0.0, 0.0, 150.0, 0.0, 0.0, 0.0))
    table = Obstacle("table", Box(3000.0, 200.0, 3000.0), (900.0, -900.0, 400.0, 0.0, 0.0, 0.0))
    fixture = Obstacle("fixture", Box(300.0, 200.0, 300.0), (1000.0, -700.0, 400.0, 0.0, 0.0, 0.0))
    tracker = Tracker((3000.0, -300.0, 400.0), acceptance=float(np.radians(60.0)))
    return desc, cell_for(desc, obstacles=(table, fixture), tracker=tracker), "pose"


def _library_distance_us(repeat: int = 20000) -> float:
    capsule = fcl.CollisionObject(fcl.Capsule(40.0, 400.0), fcl.Transform())
    box = fcl.CollisionObject(fcl.Box(800.0, 600.0, 20.0), fcl.Transform())
    shifts = np.random.default_rng(0).normal(size=(repeat, 3)) * 300.0
    started = time.perf_counter()
    for s in shifts:
        capsule.setTranslation(s)
        fcl.distance(capsule, box, fcl.DistanceRequest(), fcl.DistanceResult())
    return (time.perf_counter() - started) / repeat * 1e6


def _robot(name: str, make: object) -> tuple[dict[str, object], list[dict[str, object]]]:
    desc, cell, measurement = make()  # type: ignore[operator]
    q = sample_workspace(desc, M, seed=3)
    check_poses(desc, cell, q)  # warm: the frames' Function
    check_s = best_of(lambda: check_poses(desc, cell, q))
    seen = check_poses(desc, cell, q)
    design_poses(desc, K, "D", measurement, candidate_count=200, seed=9, cell=cell)  # warm

    def plain() -> object:
        return design_poses(desc, K, "D", measurement, candidate_count=M, seed=1)

    def in_cell() -> object:
        return design_poses(desc, K, "D", measurement, candidate_count=M, seed=1, cell=cell)

    plain_s, cell_s = best_of(plain), best_of(in_cell)
    # CPU seconds beside the wall time: what the machine's other load does not inflate.
    plain_cpu, cell_cpu = best_of(plain, clock=time.process_time), best_of(in_cell, clock=time.process_time)
    d = design_poses(desc, K, "D", measurement, candidate_count=M, seed=1, cell=cell)
    chosen = check_poses(desc, cell, d.joints)
    out = {
        f"{name}_check_us_per_candidate": check_s / M * 1e6,
        f"{name}_feasible_share": float(seen.feasible.mean()),
        f"{name}_refused": seen.counts,
        f"{name}_design_s": plain_s,
        f"{name}_design_cell_s": cell_s,
        f"{name}_design_time_ratio": cell_s / plain_s,
        f"{name}_design_cpu_s": plain_cpu,
        f"{name}_design_cell_cpu_s": cell_cpu,
        f"{name}_design_cpu_ratio": cell_cpu / plain_cpu,
        f"{name}_offered_with_cell": d.constraints["offered"],
        f"{name}_excluded_with_cell": d.constraints["excluded"],
        f"{name}_efficiency_with_cell": d.efficiency,
        f"{name}_certified_with_cell": bool(d.bound and d.bound["certified"]),
        f"{name}_chosen_feasible": int(chosen.feasible.sum()),
    }
    targets = [
        target(
            f"{name}: design CPU time with the cell / without (K=30, M=2000)", cell_cpu / plain_cpu, TIME_RATIO_LIMIT
        ),
        target(f"{name}: designed poses feasible", float(chosen.feasible.sum()), float(K), ">="),
    ]
    return out, targets


def run() -> dict[str, object]:
    results: dict[str, object] = {"fcl_capsule_box_distance_us": _library_distance_us()}
    targets: list[dict[str, object]] = []
    for name, make in (("ur5", _ur5), ("iwr", _iwr)):
        out, more = _robot(name, make)
        results.update(out)
        targets += more
    results["targets"] = targets
    return results
