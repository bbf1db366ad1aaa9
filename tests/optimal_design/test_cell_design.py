"""Designs inside a cell (DesignInputs.cell): every chosen pose collision-free and seen, by an independent check."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from models.cell import Box, Cell, Obstacle, Tracker, cell_for, stage_frames
from models.description.examples import ur5_like
from models.description.iwr import iwr
from models.description.robot import RobotDescription
from models.errors import InvalidInput
from models.workspace import sample_workspace
from optimal_design import design_poses
from optimal_design.problem import MAX_CANDIDATES, DesignInputs, DesignProblem
from tests.models.cell_reference import dh_frames, reference_verdicts

UR5 = ur5_like()
IWR = iwr(tool=(0.0, 0.0, 150.0, 0.0, 0.0, 0.0))


def ur5_cell() -> Cell:
    table = Obstacle("table", Box(1500.0, 1500.0, 40.0), (0.0, 0.0, -21.0, 0.0, 0.0, 0.0))
    fixture = Obstacle("fixture", Box(300.0, 300.0, 300.0), (500.0, 300.0, 150.0, 0.0, 0.0, 0.2))
    tracker = Tracker((2500.0, 0.0, 600.0), acceptance=np.radians(60.0))
    return cell_for(UR5, obstacles=(table, fixture), tracker=tracker)


def iwr_cell() -> Cell:
    # The IWR's workspace spans x 740-1010, y -880-130, z -550-1350 mm (its base frame): a table below it in y, a
    # fixture on the table reaching into the workspace, a tracker 2 m in front where the tool mostly faces.
    table = Obstacle("table", Box(3000.0, 200.0, 3000.0), (900.0, -900.0, 400.0, 0.0, 0.0, 0.0))
    fixture = Obstacle("fixture", Box(300.0, 200.0, 300.0), (1000.0, -700.0, 400.0, 0.0, 0.0, 0.0))
    tracker = Tracker((3000.0, -300.0, 400.0), acceptance=np.radians(60.0))
    return cell_for(IWR, obstacles=(table, fixture), tracker=tracker)


def frames_of(desc: RobotDescription, q: np.ndarray) -> np.ndarray:
    # The UR5's frames by the textbook DH product; the IWR's hexapod needs its closure solved, so its frames are
    # the model's (the last equals the forward kinematics: tests/models/test_cell.py); the distances, angles and
    # verdicts below are the hand-written ones either way.
    return dh_frames(desc, q) if desc is UR5 else stage_frames(desc, q)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(("desc", "make", "measurement"), [(UR5, ur5_cell, "position"), (IWR, iwr_cell, "pose")])
def test_every_designed_pose_is_collision_free_and_seen(
    desc: RobotDescription, make: Callable[[], Cell], measurement: str
) -> None:
    cell = make()
    design = design_poses(desc, 30, "D", measurement, candidate_count=600, seed=2, cell=cell)
    ref, _ = reference_verdicts(desc, cell, design.joints, frames_of(desc, design.joints))
    assert ref == [""] * 30
    # Refusals were counted by reason, and the certificate covers the feasible candidates
    excluded = design.constraints["excluded"]
    assert {"incidence", "cell_collision"} <= set(excluded)
    assert design.constraints["offered"] - sum(excluded.values()) >= design.candidates == 600
    assert design.bound is not None and design.bound["certified"]
    assert design.efficiency is not None and design.efficiency > 0.9


@pytest.mark.slow  # ~2.4 s: the reference check over every refused candidate: outside the inner loop (make test-fast)
def test_refused_candidates_are_the_ones_the_reference_refuses() -> None:
    cell = ur5_cell()
    given = sample_workspace(UR5, 1500, seed=5)
    problem = DesignProblem.build(UR5, DesignInputs(measurement="position", candidates=given, cell=cell))
    ref, ambiguous = reference_verdicts(UR5, cell, given, dh_frames(UR5, given))
    kept = np.zeros(len(given), bool)
    kept[problem.origin] = True
    clear = ~ambiguous
    assert np.array_equal(kept[clear], np.array([r == "" for r in ref])[clear])
    # each refused candidate counted once, under the reason the reference gives where it is unambiguous
    assert sum(problem.excluded.values()) == int((~kept).sum())
    for reason, n in problem.excluded.items():
        clear_ones = sum(1 for k in np.flatnonzero(clear) if ref[k] == reason)
        assert clear_ones <= n <= clear_ones + int(ambiguous.sum())


def test_a_cell_that_refuses_everything_says_why() -> None:
    boxed_in = Obstacle("cage", Box(4000.0, 4000.0, 4000.0), (0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    cell = cell_for(UR5, tracker=Tracker((2500.0, 0.0, 600.0)))
    cell = Cell(cell.geometry, (boxed_in,), cell.tracker, clearance=cell.clearance, allowed=cell.allowed)
    with pytest.raises(InvalidInput, match=r"cell_collision"):
        design_poses(UR5, 30, "D", "position", candidates=sample_workspace(UR5, 200, seed=1), cell=cell)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_cell_that_sees_little_stops_sampling_at_the_cap() -> None:
    # A 4° cone sees ~0.1 % of random orientations: 2 000 feasible candidates would need ~2 million samples
    cell = cell_for(UR5, tracker=Tracker((2500.0, 0.0, 600.0), acceptance=np.radians(4.0)))
    problem = DesignProblem.build(UR5, DesignInputs(measurement="position", candidate_count=2000, seed=3, cell=cell))
    assert problem.offered <= MAX_CANDIDATES
    assert 0 < problem.info.size < 2000
    assert sum(problem.excluded.values()) == problem.offered - problem.info.size
