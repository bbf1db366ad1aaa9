"""The check before a program goes to a controller: the nominal model against what the pendant displays, and
each slip named — against readings simulated with the slip made on purpose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import forward_kinematics, sample_workspace
from models.compensation.pendant import check_pendant
from models.description.examples import ur5_like

DESC = ur5_like()
JOINTS = sample_workspace(DESC, 6, seed=12)


def _displayed(theta: np.ndarray, joints: np.ndarray = JOINTS) -> tuple[np.ndarray, np.ndarray]:
    """What a controller running the model `theta` displays: the TCP in its robot-base frame."""
    at_base = theta.copy()
    at_base[DESC.slices["base"]] = 0.0
    fk = forward_kinematics(DESC, joints, at_base)
    return fk.positions, fk.rotations


def test_the_same_model_reproduces_the_pendant() -> None:
    positions, rotations = _displayed(DESC.parameters.nominal)
    moved = DESC.parameters.nominal.copy()
    moved[DESC.slices["base"]] = [1500.0, -200.0, 30.0, 0.1, 0.0, 0.5]  # where a tracker stood: not the pendant's
    found = check_pendant(DESC, moved, JOINTS, positions + 0.01, rotations)
    assert found.agrees and found.position_errors_mm.max() == pytest.approx(0.01 * math.sqrt(3), rel=1e-6)


def test_another_tool_is_named_with_its_offset_in_the_tool_frame() -> None:
    longer = DESC.parameters.nominal.copy()
    longer[DESC.parameters.index["tool.z"]] += 100.0
    positions, _ = _displayed(longer)
    found = check_pendant(DESC, DESC.parameters.nominal, JOINTS, positions)
    assert not found.agrees and "tool is not the model's" in str(found.finding)
    assert "100.000] mm" in str(found.finding)


def test_joints_in_radians_are_named() -> None:
    positions, _ = _displayed(DESC.parameters.nominal)
    as_given = JOINTS * math.pi / 180  # radians typed where degrees were expected
    found = check_pendant(DESC, DESC.parameters.nominal, as_given, positions)
    assert not found.agrees and "radians" in str(found.finding)


def test_positions_in_metres_are_named_and_another_robot_is_not_guessed() -> None:
    positions, _ = _displayed(DESC.parameters.nominal)
    found = check_pendant(DESC, DESC.parameters.nominal, JOINTS, positions / 1000)
    assert not found.agrees and "metres" in str(found.finding)
    other = sample_workspace(DESC, 6, seed=13)  # readings of other joints: no slip explains them
    found = check_pendant(DESC, DESC.parameters.nominal, other, positions)
    assert not found.agrees and "does not reproduce the pendant" in str(found.finding)
