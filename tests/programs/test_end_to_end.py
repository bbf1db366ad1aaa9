"""A program compensated for the true robot, then run by the nominal controller, lands on its targets.

The UR5-like arm with perturbed "true" parameters (thesis-sized link errors, the base 3 m away and turned 30°,
a tool off by 0.5 mm and 0.2°) used as the calibrated ones: an independent truth. Each format's program of 25
targets is compensated, re-read from its rewritten text, and run: the nominal model's solution in the
configuration the program was taught in, then the true forward kinematics. Without compensation the same run
misses by millimetres. KRL and RAPID teach their targets in a base (BASE_DATA[1], a wobjdata) with a declared
tool (TOOL_DATA[1], a tooldata); URScript and CSV in the robot's base with the model's tool."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from harness.programs import (
    FIXTURE,
    HOME_DEG,
    Cell,
    csv_table,
    executed,
    joints,
    krl_config,
    krl_pair,
    rapid_module,
    taught,
    ur5_cell,
    urscript_program,
    world_positions,
)
from models._types import Array
from programs import PROGRAM, Program, read_program
from service.services.programs import compensate_program

N_TARGETS = 25


@dataclass(frozen=True)
class Case:
    program: str
    files: dict[str, str]
    base: Array | None
    tool: Array | None


def _case(cell: Cell, format_name: str, q: Array) -> Case:
    if format_name == "krl":
        poses = list(taught(cell, q, base=FIXTURE, tool=cell.tool))
        src, dat = krl_pair(poses, q)
        return Case(src, {"weld.dat": dat, "$config.dat": krl_config(FIXTURE, cell.tool)}, FIXTURE, cell.tool)
    if format_name == "rapid":
        poses = list(taught(cell, q, base=FIXTURE, tool=cell.tool))
        return Case(rapid_module(poses, q, base=FIXTURE, tool=cell.tool), {}, FIXTURE, cell.tool)
    poses = list(taught(cell, q))
    return Case(urscript_program(poses) if format_name == "urscript" else csv_table(poses), {}, None, None)


@pytest.fixture(scope="module")
def cell() -> Cell:
    return ur5_cell()


def _poses(program: Program) -> Array:
    return np.array([t.pose for t in program.targets])


@pytest.mark.parametrize("format_name", ["krl", "rapid", "urscript", "csv"])
def test_a_compensated_program_run_by_the_nominal_controller_reaches_its_targets(cell: Cell, format_name: str) -> None:
    q = joints(N_TARGETS, seed=7)
    case = _case(cell, format_name, q)
    program = read_program(format_name, case.program, case.files)
    assert len(program.targets) == N_TARGETS
    wanted = world_positions(cell, _poses(program), case.base)

    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    assert all(o.pose is not None for o in done.outcomes), [o.reason for o in done.outcomes if o.reason]
    again = read_program(format_name, done.texts[PROGRAM], {k: v for k, v in done.texts.items() if k is not None})

    run = {"base": case.base, "tool": case.tool}
    compensated = np.linalg.norm(executed(cell, _poses(again), q, **run) - wanted, axis=1)
    uncompensated = np.linalg.norm(executed(cell, _poses(program), q, **run) - wanted, axis=1)
    assert compensated.max() <= 0.05, compensated.max()
    assert np.all(compensated <= 0.2 * uncompensated), (compensated, uncompensated)
    assert uncompensated.mean() > 0.5  # the truth is far enough from the nominal robot for the test to mean something
