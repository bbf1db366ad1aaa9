"""Bad joint vectors give domain errors that name the value and the reason."""

from __future__ import annotations

import numpy as np
import pytest

from models import (
    JointOutOfRange,
    NonFiniteValue,
    RobotDescription,
    UnreachablePose,
    WrongShape,
    forward_kinematics,
    inverse_hexapod,
    sample_workspace,
)


@pytest.fixture
def good(desc: RobotDescription) -> np.ndarray:
    return sample_workspace(desc, 3, seed=1)


def test_wrong_length(desc: RobotDescription, good: np.ndarray) -> None:
    with pytest.raises(WrongShape, match="10 numbers"):
        forward_kinematics(desc, good[:, :9])


def test_not_numbers(desc: RobotDescription) -> None:
    with pytest.raises(WrongShape):
        forward_kinematics(desc, [["a"] * 10])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite(desc: RobotDescription, good: np.ndarray, bad: float) -> None:
    joints = good.copy()
    joints[1, 6] = bad
    with pytest.raises(NonFiniteValue) as err:
        forward_kinematics(desc, joints)
    assert err.value.data == {"pose": 1, "joint": "l3"}


def test_joint_out_of_range_names_joint_value_and_limit(desc: RobotDescription, good: np.ndarray) -> None:
    joints = good.copy()
    joints[2, 2] = np.radians(181.0)
    with pytest.raises(JointOutOfRange) as err:
        forward_kinematics(desc, joints)
    data = err.value.data
    assert (data["pose"], data["joint"], data["unit"]) == (2, "q3", "deg")
    assert data["value"] == pytest.approx(181.0)
    assert data["max"] == pytest.approx(180.0)
    assert "q3" in err.value.detail and "181" in err.value.detail


def test_leg_outside_stroke(desc: RobotDescription, good: np.ndarray) -> None:
    joints = good.copy()
    joints[0, 4] = 560.0
    with pytest.raises(JointOutOfRange, match="l1"):
        forward_kinematics(desc, joints)


def test_legs_that_cannot_assemble(desc: RobotDescription, good: np.ndarray) -> None:
    """Within each stroke, but mutually impossible: three short legs and three long ones on one side."""
    joints = good.copy()
    joints[0, 4:] = [370.0, 550.0, 370.0, 550.0, 370.0, 550.0]
    with pytest.raises(UnreachablePose) as err:
        forward_kinematics(desc, joints)
    assert err.value.data["pose"] == 0
    assert err.value.data["reason"] in {"no_assembly", "outside_workspace", "near_singularity"}


def test_legs_that_land_outside_the_workspace(desc: RobotDescription, good: np.ndarray) -> None:
    """A valid assembly, but tilted 30° about x: far outside the hexapod's working box."""
    platform = np.array([[0.0, 0.0, 400.0, 0.0, 0.0, np.radians(30.0)]])
    legs = inverse_hexapod(desc, platform)[0]
    assert np.all((legs > 370) & (legs < 550))
    joints = good.copy()
    joints[1, 4:] = legs
    with pytest.raises(UnreachablePose) as err:
        forward_kinematics(desc, joints)
    assert err.value.data == {"pose": 1, "reason": "outside_workspace", "count": 1}


def test_good_input_passes(desc: RobotDescription, good: np.ndarray) -> None:
    result = forward_kinematics(desc, good)
    assert result.positions.shape == (3, 3)
    assert np.all(np.isfinite(result.positions))
