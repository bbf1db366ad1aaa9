"""Bad targets get a reason each and never stop the batch; bad request options get a domain error."""

from __future__ import annotations

import numpy as np
import pytest

from models import RobotDescription, forward_kinematics, sample_workspace
from models.compensation import inverse_kinematics
from models.errors import InvalidInput, JointOutOfRange, NonFiniteValue, WrongShape
from models.transforms import matrix_to_quaternion


@pytest.fixture(scope="module")
def targets(desc: RobotDescription) -> tuple[np.ndarray, np.ndarray]:
    fk = forward_kinematics(desc, sample_workspace(desc, 5, seed=41))
    return fk.positions, matrix_to_quaternion(fk.rotations)


def test_bad_targets_are_flagged_one_by_one(desc: RobotDescription, targets: tuple[np.ndarray, np.ndarray]) -> None:
    positions, quats = (a.copy() for a in targets)
    quats[1] *= 1.5
    positions[2, 0] = np.nan
    quats[3] = [np.inf, 0, 0, 0]
    quats[4] *= 1 + 5e-4  # near-unit: normalised and answered
    answer = inverse_kinematics(desc, positions, quats)
    assert answer.reachable.tolist() == [True, False, False, False, True]
    assert answer.reasons[1] is not None and "norm 1.5" in answer.reasons[1]
    assert answer.reasons[2] is not None and "not finite" in answer.reasons[2]
    assert answer.reasons[3] is not None and "not finite" in answer.reasons[3]
    assert np.isnan(answer.joints[1:4]).all()
    assert answer.methods[1:4] == ("invalid", "invalid", "invalid")


def test_bad_seed_weights_and_shapes(desc: RobotDescription, targets: tuple[np.ndarray, np.ndarray]) -> None:
    positions, quats = targets
    with pytest.raises(WrongShape, match="10 numbers"):
        inverse_kinematics(desc, positions, quats, seed=np.zeros(9))
    seed = sample_workspace(desc, 1, seed=1)[0]
    seed[0] = 900.0
    with pytest.raises(JointOutOfRange, match="q1"):
        inverse_kinematics(desc, positions, quats, seed=seed)
    seed[0] = np.nan
    with pytest.raises(NonFiniteValue):
        inverse_kinematics(desc, positions, quats, seed=seed)
    with pytest.raises(InvalidInput, match="non-negative"):
        inverse_kinematics(desc, positions, quats, weights=-np.ones(10))
    with pytest.raises(WrongShape, match="N × 3"):
        inverse_kinematics(desc, positions[:, :2], quats)
    with pytest.raises(WrongShape, match="orientations"):
        inverse_kinematics(desc, positions, quats[:3])
