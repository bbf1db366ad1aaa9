"""Compensation: 1 000 targets in one call, one target at a time, and IPOPT alone as the baseline."""

from __future__ import annotations

import time
from collections import Counter

import numpy as np

from benchmarks.timing import best_of, median_of, target
from models import forward_kinematics, iwr, sample_workspace
from models.compensation import inverse_kinematics
from models.identification import identify
from models.inverse import default_seed, routing, starts
from models.inverse.problem import joint_weights
from models.runtime import runtime_for
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion


def run() -> dict[str, object]:
    desc = iwr()
    sim = perturbed_robot(desc, seed=1)
    theta = identify(desc, measure(sim, sample_workspace(desc, 60, seed=11), seed=12)).parameters
    fk = forward_kinematics(desc, sample_workspace(desc, 1000, seed=5), theta)
    positions, quats = fk.positions, matrix_to_quaternion(fk.rotations)

    started = time.perf_counter()
    first = inverse_kinematics(desc, positions[:1], quats[:1], theta)  # builds the table of this calibration
    first_s = time.perf_counter() - started
    batch_s = best_of(lambda: inverse_kinematics(desc, positions, quats, theta), 3)
    answer = inverse_kinematics(desc, positions, quats, theta)
    single_ms = 1e3 * median_of(lambda: inverse_kinematics(desc, positions[7], quats[7], theta), 50)
    methods = Counter(answer.methods)

    # Baseline: IPOPT on every target from the same starting points (one mapped call).
    n = positions.shape[0]
    target_rows = np.hstack([positions, fk.rotations.transpose(0, 2, 1).reshape(n, 9)])
    table = starts.start_table(desc, theta)
    _, nearest = table.pose_tree.query(starts.features(positions, fk.rotations))
    seeds = np.tile(default_seed(desc), (n, 1))
    started = time.perf_counter()
    batch = routing.IkBatch(
        desc, theta, target_rows, seeds, joint_weights(desc, None), position_only=False, runtime=runtime_for(desc)
    )
    routing.ipopt_solutions(batch, start=table.start[nearest], exact=True)
    ipopt_s = time.perf_counter() - started
    return {
        "first_call_new_calibration_s": first_s,
        "batch_1000_s": batch_s,
        "single_target_median_ms": single_ms,
        "ipopt_only_1000_s": ipopt_s,
        "speedup_vs_ipopt_only": ipopt_s / batch_s,
        "methods": dict(methods),
        "reachable": int(answer.reachable.sum()),
        "max_position_error_mm": float(np.max(answer.position_error_mm)),
        "first_reachable": bool(first.reachable[0]),
        "targets": [
            target("1000 targets, one call (s)", batch_s, 2.0),
            target("one target, median after warm-up (ms)", single_ms, 20.0),
        ],
    }
