"""The branch check of the nominal solve (`IkBatch.jacobian_determinant`) against the determinant of the arm's
Jacobian by central differences of forward kinematics (positions in mm, rotations as rotation vectors; the
IK's rotation equations are scaled by 1000 mm, so the two differ by a factor of 1e9): a wrist flip changes
its sign (the UR5-like arm's determinant has a factor sin q5), a stretched elbow makes it vanish (sin q3)."""

from __future__ import annotations

import numpy as np
import pytest

from harness.programs import HOME_DEG, Cell, ur5_cell
from models.engine.runtime import runtime_for
from models.inverse.problem import joint_weights
from models.inverse.routing import IkBatch
from models.kinematics import forward_kinematics
from models.transforms import matrix_to_rotvec_np


@pytest.fixture(scope="module")
def cell() -> Cell:
    return ur5_cell()


def _determinants(cell: Cell, q: np.ndarray, *, position_only: bool = False) -> np.ndarray | None:
    theta = cell.promised()
    fk = forward_kinematics(cell.desc, q, theta, check_ranges=False)
    own = np.hstack([fk.positions, fk.rotations.transpose(0, 2, 1).reshape(-1, 9)])
    rt = runtime_for(cell.desc)
    batch = IkBatch(cell.desc, theta, own, q, joint_weights(cell.desc, None), position_only, rt)
    return batch.jacobian_determinant(q, own)


def _by_differences(cell: Cell, q: np.ndarray, step: float = 1e-6) -> np.ndarray:
    theta = cell.promised()
    out = np.empty(q.shape[0])
    for k, row in enumerate(q):
        plus = forward_kinematics(cell.desc, row + step * np.eye(6), theta, check_ranges=False)
        minus = forward_kinematics(cell.desc, row - step * np.eye(6), theta, check_ranges=False)
        linear = (plus.positions - minus.positions) / (2 * step)
        angular = matrix_to_rotvec_np(plus.rotations @ minus.rotations.transpose(0, 2, 1)) / (2 * step)
        out[k] = np.linalg.det(np.hstack([linear, angular]).T)
    return out


def test_the_determinant_is_the_arms_and_its_sign_flips_with_the_wrist(cell: Cell) -> None:
    q = np.tile(np.radians(HOME_DEG), (4, 1))
    q[1] += np.radians([25.0, -20.0, 15.0, 30.0, -20.0, 40.0])
    q[2, 4] *= -1  # wrist flipped
    q[3, 2] = 1e-3  # elbow stretched
    det = _determinants(cell, q)
    assert det is not None
    np.testing.assert_allclose(det, 1e9 * _by_differences(cell, q), rtol=1e-5, atol=1e-6 * abs(det[0]))
    assert np.sign(det[2]) == -np.sign(det[0]) != 0
    assert abs(det[3]) < 1e-2 * abs(det[0])


def test_no_sign_where_the_problem_is_not_square(cell: Cell) -> None:
    # Position only: six joints for three equations, a redundant problem, which has no branch sign.
    assert _determinants(cell, np.radians([HOME_DEG]), position_only=True) is None
