"""The tolerance study (thesis §4.5): what the default request costs, and the exact model's two routes.

The issue sets no performance target for the error analysis; the one target
here is our own serving budget: the HTTP layer answers the default study
(40 poses × 200 draws) synchronously, so it should stay well under a few
seconds on this 2-core machine.

Alternative measured: the exact model evaluated draw by draw through the
validated `forward_kinematics` (what `error_analysis` does) against all
poses × draws stacked into one native batch with per-row parameters (no
validation), to know what a faster route would gain.
"""

from __future__ import annotations

import numpy as np

from benchmarks.timing import best_of, target
from models import Registry, forward_kinematics, iwr
from models.error_analysis import ErrorMagnitudes, draw_errors, error_analysis, summary
from models.kinematics import solve_platforms
from models.workspace import sample_workspace

SERVING_BUDGET_S = 2.0


def run() -> dict[str, object]:
    desc = iwr()
    rt = Registry().runtime(desc)  # the benchmark's own, like an application's
    _ = rt.kinematics
    error_analysis(desc, n_poses=4, n_draws=2, runtime=rt)  # warm the mapped Functions
    default_s = best_of(lambda: error_analysis(desc, runtime=rt), repeat=3)
    big_s = best_of(lambda: error_analysis(desc, n_poses=100, n_draws=1000, runtime=rt), repeat=1)

    joints = sample_workspace(desc, 40, 0, runtime=rt)
    assert isinstance(joints, np.ndarray)
    theta0 = desc.parameters.nominal
    deltas = draw_errors(desc, 200, ErrorMagnitudes(), "sign", np.random.default_rng(0))
    seeds = forward_kinematics(desc, joints, runtime=rt).platforms

    def per_draw() -> np.ndarray:
        return np.stack(
            [forward_kinematics(desc, joints, theta0 + d, seeds=seeds, runtime=rt).positions for d in deltas]
        )

    def stacked() -> np.ndarray:
        q = np.tile(joints, (len(deltas), 1))
        params = np.repeat(theta0 + deltas, len(joints), axis=0)
        platforms, _ = solve_platforms(desc, q, params, np.tile(seeds, (len(deltas), 1)), runtime=rt)
        pos, _ = rt.kinematics.batch("pose_at", q, params, platforms)
        return pos.reshape(len(deltas), len(joints), 3)

    per_draw_s, stacked_s = best_of(per_draw, 3), best_of(stacked, 3)
    agree_mm = float(np.abs(per_draw() - stacked()).max())
    print(summary(error_analysis(desc, runtime=rt)))
    return {
        "default_study_seconds": default_s,
        "study_100_poses_1000_draws_seconds": big_s,
        "exact_40x200_per_draw_forward_kinematics_seconds": per_draw_s,
        "exact_40x200_stacked_batch_seconds": stacked_s,
        "stacked_speedup": per_draw_s / stacked_s,
        "routes_agree_mm": agree_mm,
        "targets": [
            target("error analysis, 40 poses x 200 draws (s; own serving budget)", default_s, SERVING_BUDGET_S),
        ],
    }
