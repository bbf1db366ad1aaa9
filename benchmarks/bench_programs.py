"""Program compensation: a 10 000-target program (URScript, read, compensated, rewritten) in one call, against
compensating its targets one call each (a sample of them, the rest extrapolated), on the UR5-like arm."""

from __future__ import annotations

import time

import numpy as np

from benchmarks.timing import target
from harness.programs import HOME_DEG, joints, taught, ur5_cell, urscript_program
from models.compensation.poses import compensate_poses
from models.runtime import runtime_for
from programs import read_program
from service.services.programs import compensate_program

N_TARGETS = 10_000
ONE_BY_ONE = 200
"""Targets compensated one call each; the per-target time is their mean."""


def run() -> dict[str, object]:
    cell = ur5_cell()
    rt = runtime_for(cell.desc)
    poses = taught(cell, joints(N_TARGETS, seed=21))
    text = urscript_program(list(poses))
    home = np.radians(HOME_DEG)
    compensate_poses(cell.desc, cell.truth, cell.nominal, poses[:10], seeds=home, runtime=rt)  # builds, warms

    started = time.perf_counter()
    program = read_program("urscript", text)
    read_s = time.perf_counter() - started
    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=home, runtime=rt)
    batch_s = time.perf_counter() - started
    reached = sum(o.pose is not None for o in done.outcomes)

    started = time.perf_counter()
    for k in range(ONE_BY_ONE):
        compensate_poses(cell.desc, cell.truth, cell.nominal, poses[k : k + 1], seeds=home, runtime=rt)
    per_target_s = (time.perf_counter() - started) / ONE_BY_ONE
    return {
        "targets": [target(f"{N_TARGETS} targets, one call (s)", batch_s, 2.0)],
        "program_10000_s": batch_s,
        "read_s": read_s,
        "reached": reached,
        "per_target_call_ms": 1e3 * per_target_s,
        "one_by_one_10000_s_extrapolated": per_target_s * N_TARGETS,
        "speedup_vs_one_by_one": per_target_s * N_TARGETS / batch_s,
        "program_bytes": len(text),
    }
