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
    krl_in_fixture,
    rapid_in_fixture,
    taught,
    ur5_cell,
    urscript_program,
    world_positions,
)
from models import sample_workspace
from models._types import Array
from models.compensation.poses import pose6_matrix
from models.description.examples import ur5_like
from models.identification import identify
from models.identification.registration import rigid_fit
from models.simulation import measure, perturbed_robot
from programs import PROGRAM, Program, read_program
from service.services.programs import compensate_program

N_TARGETS = 25


@dataclass(frozen=True)
class Case:
    program: str
    files: dict[str, str]
    base: Array | None
    tool: Array | None


def _case(cell: Cell, format_name: str, q: Array, tool: Array | None = None) -> Case:
    """The program of `format_name` taught at joints `q`; KRL and RAPID declare `tool` (default: the nominal)."""
    tool = cell.tool if tool is None else tool
    if format_name == "krl":
        src, dat = krl_in_fixture(cell, q, tool)
        return Case(src, {"weld.dat": dat, "$config.dat": krl_config(FIXTURE, tool)}, FIXTURE, tool)
    if format_name == "rapid":
        return Case(rapid_in_fixture(cell, q, tool), {}, FIXTURE, tool)
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


@pytest.fixture(scope="module")
def calibrated_cell() -> tuple[Cell, Array]:
    """The issue's scenario: every DH parameter of the UR5-like arm perturbed, calibrated from 80 simulated
    tracker poses (σ 25 µm, 0.01°). The cell's `truth` is the calibration; the real robot is returned beside it."""
    desc = ur5_like()
    sim = perturbed_robot(desc, seed=3)
    campaign = measure(sim, sample_workspace(desc, 80, seed=11), seed=12)
    result = identify(desc, campaign)
    assert result.succeeded, result.reason
    return Cell(desc, sim.nominal, result.parameters), sim.truth


def _aligned(executed_at: Array, wanted: Array) -> Array:
    """The distances left after the best rigid motion of the executed points onto their targets."""
    fit = rigid_fit(executed_at, wanted)
    return np.asarray(np.linalg.norm(executed_at @ fit.rotation.T + fit.translation - wanted, axis=1))


@pytest.mark.slow  # a calibration from 80 poses, then the four formats: ~1 s
@pytest.mark.parametrize("format_name", ["krl", "rapid", "urscript", "csv"])
def test_a_program_compensated_by_a_calibration_from_80_poses_reaches_its_targets(
    calibrated_cell: tuple[Cell, Array], format_name: str
) -> None:
    """Compensated with the calibrated parameters (not the truth), run by the nominal controller on the real
    robot: within 0.05 mm of the targets after the best rigid alignment (the instrument's frame, which a
    calibration knows only to its noise) and at most 0.2x the uncompensated error, absolute and aligned.

    KRL and RAPID declare the calibrated tool as their tool data, as a cell does after a calibration: a flange
    length and a tool length are one sum to a tracker on one tool, so a tool measured otherwise would carry the
    flange's error along (that split is no calibration's to make; docs/controller.md, Frames)."""
    cell, real = calibrated_cell
    q = joints(N_TARGETS, seed=7)
    case = _case(cell, format_name, q, tool=pose6_matrix(cell.truth[cell.desc.slices["tool"]]))
    program = read_program(format_name, case.program, case.files)
    wanted = world_positions(cell, _poses(program), case.base)

    done = compensate_program(cell.desc, cell.truth, program, nominal=cell.nominal, seed=np.radians(HOME_DEG))
    assert all(o.pose is not None for o in done.outcomes), [o.reason for o in done.outcomes if o.reason]
    again = read_program(format_name, done.texts[PROGRAM], {k: v for k, v in done.texts.items() if k is not None})

    run = {"base": case.base, "tool": case.tool, "real": real}  # the real robot carries its real tool
    after = executed(cell, _poses(again), q, **run)
    before = executed(cell, _poses(program), q, **run)
    absolute, uncompensated = np.linalg.norm(after - wanted, axis=1), np.linalg.norm(before - wanted, axis=1)
    aligned, uncompensated_aligned = _aligned(after, wanted), _aligned(before, wanted)
    assert aligned.max() <= 0.05, aligned.max()
    assert np.sqrt(np.mean(absolute**2)) <= 0.2 * np.sqrt(np.mean(uncompensated**2)), (absolute, uncompensated)
    assert np.sqrt(np.mean(aligned**2)) <= 0.2 * np.sqrt(np.mean(uncompensated_aligned**2))
    assert absolute.max() <= 0.1, absolute.max()  # the instrument frame's registration, a few hundredths at most
