"""Program compensation on the UR5-like arm: a 10 000-target URScript program (read, compensated, rewritten) in
one call, split into its three steps, against compensating its targets one call each (a sample of them, the
rest extrapolated) in the same run; and a 1 000-target program in one call. The same two programs on a UR10e
imported from its kinematics file (issue 44: the goals hold on an imported robot), its targets in UR's Base."""

from __future__ import annotations

import os
import statistics
import time

import numpy as np

from benchmarks.timing import target
from harness.programs import HOME_DEG, Cell, joints, taught, taught_in, ur5_cell, ur10e_cell, urscript_program
from models._types import Array
from models.compensation.controller import ZERO, ControllerFrame
from models.compensation.poses import compensate_poses
from models.engine.runtime import Runtime, runtime_for
from programs import read_program, rewritten
from service.services.programs import compensate_program

N_TARGETS = 10_000
N_SMALL = 1_000
REPEATS = 5
"""Runs of each program after a warm-up; every number is the median."""
ONE_BY_ONE = 200
"""Targets compensated one call each; the per-target time is their mean."""


def _steps(cell: Cell, text: str, home: Array, rt: Runtime, frame: ControllerFrame = ZERO) -> dict[str, float]:
    """Seconds (wall and CPU) of one run: read, compensate and rewrite (the rewrite also timed alone)."""
    wall, cpu = time.perf_counter(), time.process_time()
    program = read_program("urscript", text)
    read_s = time.perf_counter() - wall
    done = compensate_program(
        cell.desc, cell.truth, program, nominal=cell.nominal, seed=home, runtime=rt, controller=frame
    )
    total_s, total_cpu_s = time.perf_counter() - wall, time.process_time() - cpu
    changes = [(o.target, o.pose) for o in done.outcomes if o.pose is not None]
    started = time.perf_counter()
    rewritten(program, changes)  # what compensate_program ends with, timed on its own
    rewrite_s = time.perf_counter() - started
    return {
        "total_s": total_s,
        "total_cpu_s": total_cpu_s,
        "read_s": read_s,
        "compensate_s": total_s - read_s - rewrite_s,
        "rewrite_s": rewrite_s,
        "reached": float(len(changes)),
    }


def _imported() -> dict[str, dict[str, float]]:
    """The two programs on the UR10e imported from its kinematics file, taught in UR's Base."""
    cell, frame = ur10e_cell()
    rt = runtime_for(cell.desc)
    home = np.radians(HOME_DEG)
    poses = taught_in(cell, frame, joints(N_TARGETS, seed=22))
    text, small = urscript_program(list(poses)), urscript_program(list(poses[:N_SMALL]))
    _steps(cell, small, home, rt, frame)  # builds, warms
    _steps(cell, text, home, rt, frame)
    return {
        "big": _median([_steps(cell, text, home, rt, frame) for _ in range(REPEATS)]),
        "little": _median([_steps(cell, small, home, rt, frame) for _ in range(REPEATS)]),
    }


def _median(runs: list[dict[str, float]]) -> dict[str, float]:
    return {k: statistics.median(r[k] for r in runs) for k in runs[0]}


def run() -> dict[str, object]:
    cell = ur5_cell()
    rt = runtime_for(cell.desc)
    home = np.radians(HOME_DEG)
    poses = taught(cell, joints(N_TARGETS, seed=21))
    text = urscript_program(list(poses))
    small = urscript_program(list(poses[:N_SMALL]))
    compensate_poses(cell.desc, cell.truth, cell.nominal, poses[:10], seeds=home, runtime=rt)  # builds, warms
    _steps(cell, small, home, rt)
    _steps(cell, text, home, rt)  # the batch sizes of this program's Newton passes: their maps built

    big = _median([_steps(cell, text, home, rt) for _ in range(REPEATS)])
    little = _median([_steps(cell, small, home, rt) for _ in range(REPEATS)])

    imported = _imported()

    started = time.perf_counter()
    for k in range(ONE_BY_ONE):
        compensate_poses(cell.desc, cell.truth, cell.nominal, poses[k : k + 1], seeds=home, runtime=rt)
    per_target_s = (time.perf_counter() - started) / ONE_BY_ONE
    return {
        "targets": [
            target(f"{N_TARGETS} targets, one call, median (s)", big["total_s"], 2.0),
            target(f"{N_SMALL} targets, one call, median (s)", little["total_s"], 0.2),
            target(f"UR10e from its file: {N_TARGETS} targets, one call, median (s)", imported["big"]["total_s"], 2.0),
            target(f"UR10e from its file: {N_SMALL} targets, one call, median (s)", imported["little"]["total_s"], 0.2),
        ],
        "imported_ur10e": imported,
        "program_10000_s": big["total_s"],
        "program_10000_cpu_s": big["total_cpu_s"],
        "read_s": big["read_s"],
        "compensate_s": big["compensate_s"],
        "rewrite_s": big["rewrite_s"],
        "reached": int(big["reached"]),
        "program_1000_s": little["total_s"],
        "program_1000_cpu_s": little["total_cpu_s"],
        "program_1000_split_s": {k: little[k] for k in ("read_s", "compensate_s", "rewrite_s")},
        "per_target_call_ms": 1e3 * per_target_s,
        "one_by_one_10000_s_extrapolated": per_target_s * N_TARGETS,
        "speedup_vs_one_by_one": per_target_s * N_TARGETS / big["total_s"],
        "program_bytes": len(text),
        "repeats": REPEATS,
        "load_average_1min_at_end": os.getloadavg()[0],
    }
