"""Rotation representations: numeric round trips and symbolic/numeric agreement."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from models.transforms import (
    matrix_to_quaternion,
    matrix_to_rotvec,
    matrix_to_rotvec_np,
    quaternion_to_matrix,
    rotvec_to_matrix,
    rotvec_to_matrix_np,
)

finite = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(st.tuples(finite, finite, finite, finite).filter(lambda q: np.linalg.norm(q) > 1e-3))
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_quaternion_matrix_round_trip(q: tuple[float, float, float, float]) -> None:
    quat = np.array(q) / np.linalg.norm(q)
    r = quaternion_to_matrix(quat)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(r) > 0
    back = matrix_to_quaternion(r)
    assert back[0] >= 0
    # q and -q are the same rotation; with w = 0 either sign is a valid answer
    assert min(np.abs(back - quat).max(), np.abs(back + quat).max()) < 1e-9
    np.testing.assert_allclose(quaternion_to_matrix(back), r, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.tuples(finite, finite, finite))
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_symbolic_rodrigues_and_log_match_numeric(v: tuple[float, float, float]) -> None:
    vec = np.array(v) * 2.5  # angles up to ~4.3 rad > pi are fine for Rodrigues
    r_sym = np.array(ca.Function("r", [], [rotvec_to_matrix(ca.DM(vec))])()["o0"])
    np.testing.assert_allclose(r_sym, rotvec_to_matrix_np(vec), atol=1e-12)
    if np.linalg.norm(vec) < 3.0:
        log_sym = np.array(ca.Function("l", [], [matrix_to_rotvec(ca.DM(r_sym))])()["o0"]).ravel()
        np.testing.assert_allclose(log_sym, vec, atol=1e-9)
        np.testing.assert_allclose(matrix_to_rotvec_np(r_sym), vec, atol=1e-9)


def test_rotation_vector_derivative_is_exact_at_identity() -> None:
    """d exp([v]) / dv at 0 is the skew generator: the nominal base/tool are identity rotations."""
    v = ca.SX.sym("v", 3)
    jac = ca.Function("j", [v], [ca.jacobian(ca.vec(rotvec_to_matrix(v)), v)])
    d = np.array(jac(np.zeros(3)))
    expected = np.zeros((9, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1.0
        skew = np.array([[0, -e[2], e[1]], [e[2], 0, -e[0]], [-e[1], e[0], 0]])
        expected[:, k] = skew.ravel(order="F")
    np.testing.assert_allclose(d, expected, atol=1e-15)
