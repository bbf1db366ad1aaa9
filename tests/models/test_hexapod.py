"""Hexapod: IK∘FK round trip, Newton convergence, the thesis's Jacobian (eq. 48)."""

from __future__ import annotations

import itertools

import casadi as ca
import numpy as np

from models import RobotDescription, default_registry, inverse_hexapod, sample_workspace, solve_platforms
from models.description.hexapod import split_hexapod_params
from models.kinematics import hexapod_condition
from models.transforms import euler_zyx, rotvec_to_matrix


def _workspace_corners(desc: RobotDescription) -> np.ndarray:
    assert desc.hexapod is not None
    lo, hi = np.array(desc.hexapod.workspace_min), np.array(desc.hexapod.workspace_max)
    return np.array([np.where(mask, hi, lo) for mask in itertools.product([0, 1], repeat=6)], dtype=float)


def test_ik_fk_round_trip_over_the_workspace(desc: RobotDescription) -> None:
    theta = desc.parameters.nominal
    _, random_platforms = sample_workspace(desc, 5000, seed=7, return_platforms=True)
    platforms = np.vstack([random_platforms, _workspace_corners(desc)])
    legs = inverse_hexapod(desc, platforms, theta)
    joints = np.hstack([np.full((platforms.shape[0], 4), 0.5), legs])
    solved, closure = solve_platforms(desc, joints, theta)  # Newton from the home pose, every time
    assert np.all(closure < 1e-9)
    np.testing.assert_allclose(solved[:, :3], platforms[:, :3], atol=1e-9)
    np.testing.assert_allclose(solved[:, 3:], platforms[:, 3:], atol=1e-11)
    # and back: IK of the solved pose reproduces the commanded legs
    np.testing.assert_allclose(inverse_hexapod(desc, solved, theta), legs, atol=1e-9)


def test_rootfinder_fk_converges_from_home(desc: RobotDescription) -> None:
    fk = default_registry().runtime(desc).kinematics["hexapod_fk"]
    hp = desc.parameters.nominal[desc.slices["hexapod"]]
    assert desc.hexapod is not None
    platforms = np.vstack([_workspace_corners(desc), sample_workspace(desc, 50, 3, return_platforms=True)[1]])
    for x in platforms:
        legs = inverse_hexapod(desc, x[None, :])[0]
        solved = np.array(fk(legs, hp, desc.hexapod.home)).ravel()
        np.testing.assert_allclose(solved[:3], x[:3], atol=1e-9)
        np.testing.assert_allclose(solved[3:], x[3:], atol=1e-11)


def test_thesis_jacobian_equals_automatic_differentiation(desc: RobotDescription) -> None:
    """Eq. 48 rows [u_iᵀ, (s_i × u_i)ᵀ] against AD of |p + δp + exp(ω) R b_i − a_i| at δp = ω = 0."""
    hp_num = desc.parameters.nominal[desc.slices["hexapod"]]
    x = ca.SX.sym("x", 6)
    dp, w = ca.SX.sym("dp", 3), ca.SX.sym("w", 3)
    hp = ca.SX.sym("hp", 42)
    a, b, _ = split_hexapod_params(hp)
    r = rotvec_to_matrix(w) @ euler_zyx(x[3], x[4], x[5])
    v = ca.repmat(x[0:3] + dp, 1, 6) + r @ b - a
    lengths = ca.sqrt(ca.sum1(v * v)).T
    twist = ca.vertcat(dp, w)
    ad = ca.Function("ad", [x, hp, twist], [ca.jacobian(lengths, twist)])
    closed = default_registry().runtime(desc).kinematics["hexapod_jacobian"]
    for platform in sample_workspace(desc, 30, 11, return_platforms=True)[1]:
        np.testing.assert_allclose(
            np.array(ad(platform, hp_num, np.zeros(6))), np.array(closed(platform, hp_num)), atol=1e-12
        )


def test_condition_number_flags_a_singular_hexapod(desc: RobotDescription) -> None:
    """All platform joints at the centre: the platform can spin freely about z (a singularity)."""
    theta = desc.parameters.nominal.copy()
    hexapod = desc.slices["hexapod"]
    per_leg = theta[hexapod].reshape(6, 7)
    per_leg[:, 3:6] = 0.0
    theta[hexapod] = per_leg.ravel()
    assert desc.hexapod is not None
    home = np.array([desc.hexapod.home])
    assert hexapod_condition(desc, home, theta)[0] > 1e12
    assert hexapod_condition(desc, home, desc.parameters.nominal)[0] < desc.hexapod.max_condition
