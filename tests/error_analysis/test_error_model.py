"""The exact and first-order error models against independent truths."""

from __future__ import annotations

import json

import numpy as np
import pytest

from models import RobotDescription, forward_kinematics, sample_workspace
from models.error_analysis import (
    SUBSYSTEMS,
    ErrorMagnitudes,
    carriage_frame_errors,
    error_analysis,
    pose_errors,
    subsystem_mask,
)
from models.error_analysis.export import result_json
from models.transforms import matrix_to_rotvec_np

from .conftest import carriage_frame

SCALES = (1.0, 0.5, 0.25, 0.125)


def _rms(values: np.ndarray) -> float:
    return float(np.sqrt(np.mean(values**2)))


@pytest.mark.parametrize("distribution", ["sign", "uniform"])
def test_linearisation_gap_shrinks_quadratically(desc: RobotDescription, distribution: str) -> None:
    gaps: dict[str, list[float]] = {}
    first_order: list[float] = []
    for s in SCALES:
        res = error_analysis(
            desc, n_poses=6, n_draws=8, tolerances=ErrorMagnitudes().scaled(s), distribution=distribution, seed=5
        )
        for sub in SUBSYSTEMS:
            gap = res.errors[sub].gap
            gaps.setdefault(f"{sub}.position", []).append(_rms(gap[..., :3]))
            gaps.setdefault(f"{sub}.orientation", []).append(_rms(gap[..., 3:]))
        gaps.setdefault("carriage_frame.position", []).append(_rms(res.carriage_frame.gap[..., :3]))
        gaps.setdefault("superposition.position", []).append(_rms(res.superposition_gap()[..., :3]))
        first_order.append(_rms(res.errors["whole"].first_order[..., :3]))
    # The first-order errors scale linearly (same random pattern at every scale) ...
    np.testing.assert_allclose(np.array(first_order) / first_order[0], SCALES, rtol=1e-12)
    for name, values in gaps.items():
        # ... and the gap stays far above round-off (1e-12 mm or rad) even at the smallest scale ...
        assert values[-1] > 1e-9, (name, values)
        # ... and divides by four each time the tolerances halve.
        ratios = np.array(values[:-1]) / np.array(values[1:])
        assert np.all((ratios > 3.9) & (ratios < 4.1)), (name, ratios)


def test_zero_tolerances_give_zero_errors(desc: RobotDescription) -> None:
    res = error_analysis(desc, n_poses=5, n_draws=3, tolerances=ErrorMagnitudes(0.0, 0.0, 0.0, 0.0), seed=2)
    assert not np.any(res.deltas)
    for sub in SUBSYSTEMS:
        assert np.max(np.abs(res.errors[sub].exact)) < 1e-10
        assert not np.any(res.errors[sub].first_order)
    assert np.max(np.abs(res.carriage_frame.exact)) < 1e-12
    # No error, no share: null in the JSON rather than NaN.
    data = result_json(res)
    json.dumps(data, allow_nan=False)
    assert data["shares"]["exact"]["position"]["carriage"]["mean_abs_ratio"] is None


def test_subsystems_decompose_the_whole(desc: RobotDescription) -> None:
    res = error_analysis(desc, n_poses=6, n_draws=10, seed=1)
    e = res.errors
    # By linearity the first-order whole is exactly carriage + hexapod.
    np.testing.assert_allclose(
        e["whole"].first_order, e["carriage"].first_order + e["hexapod"].first_order, rtol=0, atol=1e-12
    )
    # The cases partition the perturbed parameters: carriage and hexapod, never base or tool.
    np.testing.assert_array_equal(res.masks["carriage"] + res.masks["hexapod"], res.masks["whole"])
    assert not np.any(res.masks["carriage"] * res.masks["hexapod"])
    for group in ("base", "tool"):
        assert not np.any(res.deltas[:, desc.slices[group]])
    # "sign" draws: every perturbed parameter off by exactly its tolerance (thesis's magnitudes).
    whole = res.masks["whole"] > 0
    np.testing.assert_allclose(np.abs(res.deltas[:, whole]), np.broadcast_to(res.tolerance_vector[whole], (10, 58)))
    assert res.tolerance_vector[desc.parameters.index["link2.alpha"]] == pytest.approx(np.radians(0.1))
    assert res.tolerance_vector[desc.parameters.index["leg3.offset"]] == 0.5
    assert res.tolerance_vector[desc.parameters.index["leg3.b.y"]] == 0.1
    for quantity in ("position", "orientation"):
        total = res.variance_share("carriage", "exact", quantity) + res.variance_share("hexapod", "exact", quantity)
        assert total == pytest.approx(1.0)


def test_uniform_draws_stay_within_tolerance(desc: RobotDescription) -> None:
    res = error_analysis(desc, n_poses=2, n_draws=50, distribution="uniform", seed=4)
    bound = np.broadcast_to(res.tolerance_vector, res.deltas.shape)
    assert np.all(np.abs(res.deltas) <= bound)
    whole = res.masks["whole"] > 0
    assert np.mean(np.abs(res.deltas[:, whole]) < 0.5 * bound[:, whole]) == pytest.approx(0.5, abs=0.05)


def test_rail_axis_angle_error_is_a_rotation_about_z0(desc: RobotDescription) -> None:
    """Δθ1 prepends Rz(Δθ1) to the whole chain (base = identity): the TCP turns about the world z axis."""
    joints = sample_workspace(desc, 5, 7)
    assert isinstance(joints, np.ndarray)
    angle = np.radians(0.5)
    delta = desc.parameters.with_values(np.zeros(desc.n_params), {"link1.theta": angle})
    errors = pose_errors(desc, joints, delta)
    p = forward_kinematics(desc, joints).positions
    c, s = np.cos(angle), np.sin(angle)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(errors.exact[0, :, :3], p @ (rz - np.eye(3)).T, atol=1e-9)
    np.testing.assert_allclose(errors.exact[0, :, 3:], np.tile([0.0, 0.0, angle], (5, 1)), atol=1e-12)
    first = np.cross([0.0, 0.0, angle], p)
    np.testing.assert_allclose(errors.first_order[0, :, :3], first, atol=1e-9)
    np.testing.assert_allclose(errors.first_order[0, :, 3:], np.tile([0.0, 0.0, angle], (5, 1)), atol=1e-12)


def test_shifting_the_base_plate_joints_translates_the_tcp(desc: RobotDescription) -> None:
    """All a_i moved by t (frame {4}) with the legs unchanged: the platform moves by t, the TCP by R_04 t."""
    joints = sample_workspace(desc, 5, 8)
    assert isinstance(joints, np.ndarray)
    shift = np.array([0.3, -0.2, 0.15])
    updates = {f"leg{i}.a.{c}": shift[k] for i in range(1, 7) for k, c in enumerate("xyz")}
    delta = desc.parameters.with_values(np.zeros(desc.n_params), updates)
    errors = pose_errors(desc, joints, delta)
    expected = np.array([carriage_frame(q[:4])[:3, :3] @ shift for q in joints])
    for model in (errors.exact, errors.first_order):
        np.testing.assert_allclose(model[0, :, :3], expected, atol=1e-9)
        np.testing.assert_allclose(model[0, :, 3:], 0.0, atol=1e-12)


def test_carriage_frame_errors_match_a_hand_written_dh_chain(desc: RobotDescription) -> None:
    joints = sample_workspace(desc, 4, 9)
    assert isinstance(joints, np.ndarray)
    rng = np.random.default_rng(3)
    delta = np.zeros(desc.n_params)
    delta[desc.slices["carriage"]] = rng.uniform(-1.0, 1.0, 16) * np.tile([0.01, 2.0, 2.0, 0.01], 4)
    delta[desc.slices["hexapod"]] = 1.0  # ignored: only the carriage moves its own frame
    errors = carriage_frame_errors(desc, joints, delta)
    for n, q in enumerate(joints):
        nominal, perturbed = carriage_frame(q[:4]), carriage_frame(q[:4], delta[desc.slices["carriage"]])
        np.testing.assert_allclose(errors.exact[0, n, :3], perturbed[:3, 3] - nominal[:3, 3], atol=1e-9)
        rot = matrix_to_rotvec_np(perturbed[:3, :3] @ nominal[:3, :3].T)
        np.testing.assert_allclose(errors.exact[0, n, 3:], rot, atol=1e-12)
    # Large errors (0.6°, 2 mm): the first-order model is close but visibly not exact.
    gap = np.abs(errors.gap).max()
    assert 1e-4 < gap < 0.05 * np.abs(errors.exact).max()


@pytest.mark.slow  # Monte Carlo: 500 draws per distribution
@pytest.mark.parametrize(("distribution", "variance"), [("sign", 1.0), ("uniform", 1.0 / 3.0)])
def test_monte_carlo_rms_matches_the_expected_variance(
    desc: RobotDescription, distribution: str, variance: float
) -> None:
    """E[(J δ)_k²] = var · Σ_j J_kj² tol_j² for independent zero-mean errors: the reported RMS converges to it."""
    res = error_analysis(desc, n_poses=4, n_draws=500, distribution=distribution, seed=11)
    stats = result_json(res)["subsystems"]
    for sub in SUBSYSTEMS:
        tol = res.tolerance_vector * subsystem_mask(desc, sub)
        expected = np.sqrt(variance * np.mean((res.jacobians**2) @ (tol**2), axis=0))
        reported = [stats[sub]["first_order"]["position"]["rms_mm"][a] for a in "xyz"]
        reported += [np.radians(stats[sub]["first_order"]["orientation"]["rms_deg"][a]) for a in "xyz"]
        np.testing.assert_allclose(reported, expected, rtol=0.08)


def test_worst_case_bounds_every_draw(desc: RobotDescription) -> None:
    res = error_analysis(desc, n_poses=6, n_draws=30, seed=6)
    for sub in SUBSYSTEMS:
        for quantity, rows in (("position", slice(0, 3)), ("orientation", slice(3, 6))):
            worst = res.worst_cases[sub][quantity]
            drawn = np.abs(res.errors[sub].first_order[..., rows]).reshape(-1, 3).max(axis=0)
            assert np.all(drawn <= worst.first_order * (1 + 1e-12))
            np.testing.assert_allclose(worst.exact, worst.first_order, rtol=0.02)


def test_same_seed_same_study(desc: RobotDescription) -> None:
    a = result_json(error_analysis(desc, n_poses=3, n_draws=4, seed=21))
    b = result_json(error_analysis(desc, n_poses=3, n_draws=6, seed=21))
    c = result_json(error_analysis(desc, n_poses=3, n_draws=4, seed=21))
    assert a["per_pose"]["joints"] == b["per_pose"]["joints"]
    expected = sample_workspace(desc, 3, 21) * desc.joint_to_boundary
    np.testing.assert_allclose(a["per_pose"]["joints"], expected)
    a.pop("seconds"), c.pop("seconds")
    assert a == c
