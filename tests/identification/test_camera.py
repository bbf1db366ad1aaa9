"""Calibration from a calibrated camera (the `image` record kind): its projection against an independent numpy
one and hand-computed values, its derivatives against finite differences through the real forward
kinematics, what it can identify, recovery of the robot and the camera's pose over seeds, and the slips a camera
file makes."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest
import scipy.stats

from harness.ballbar import aligned_rms, predicted_rms
from harness.camera import (
    INTRINSICS,
    MARKERS,
    WORLD_CAMERA,
    CameraCampaign,
    project,
    tool_camera_campaign,
    world_camera_campaign,
    world_images,
)
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.engine.runtime import runtime_for
from models.errors import InvalidInput, TooFewMeasurements
from models.identification.reference_fit import ReferenceProblem, identify_references, reference_problem
from models.measurements.camera import Camera, Intrinsics, ToolCamera, read_images
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np

DESC = ur5_like()
SIGMA_PX = 0.1
LENS = Intrinsics(2000.0, 1995.0, 1024.0, 768.0, (-0.12, 0.03, 2e-4, -1.5e-4, 0.01))


# ---------------------------------------------------------------------------------------------- projection
def test_the_projection_is_opencvs_pinhole_with_distortion() -> None:
    # By hand: X = (100, 50, 1000) → x' = 0.1, y' = 0.05, r² = 0.0125; with k1 = −0.2 alone ρ = 0.9975,
    # u = 2000 · 0.09975 + 1024 = 1223.5, v = 1995 · 0.049875 + 768 = 867.500625; with p1 = 0.01 alone
    # x'' = 0.1 + 2 · 0.01 · 0.005 = 0.1001, y'' = 0.05 + 0.01 · (0.0125 + 0.005) = 0.050175.
    point = np.array([[100.0, 50.0, 1000.0]])
    radial = Intrinsics(2000.0, 1995.0, 1024.0, 768.0, (-0.2, 0.0, 0.0, 0.0, 0.0)).project(point)[0]
    np.testing.assert_allclose(radial[0], [1223.5, 867.500625], rtol=0, atol=1e-9)
    tangential = Intrinsics(2000.0, 1995.0, 1024.0, 768.0, (0.0, 0.0, 0.01, 0.0, 0.0)).project(point)[0]
    np.testing.assert_allclose(tangential[0], [2000 * 0.1001 + 1024, 1995 * 0.050175 + 768], rtol=0, atol=1e-9)
    # Against the harness's independent numpy projection, over the field of view, every coefficient on.
    rng = np.random.default_rng(0)
    points = np.column_stack([rng.uniform(-600, 600, (200, 2)), rng.uniform(800, 2500, 200)])
    spec = {"fx": LENS.fx, "fy": LENS.fy, "cx": LENS.cx, "cy": LENS.cy, "distortion": list(LENS.distortion)}
    np.testing.assert_allclose(LENS.project(points)[0], project(points, spec), rtol=0, atol=1e-9)
    # Undistortion inverts it, and a point behind the camera projects nowhere.
    xy = LENS.normalised(project(points, spec))
    np.testing.assert_allclose(xy, points[:, :2] / points[:, 2:], atol=1e-10)
    assert np.all(np.isnan(LENS.project(np.array([[10.0, 0.0, -500.0]]))[0]))


def test_the_projection_derivative_matches_finite_differences() -> None:
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-500, 500, (20, 2)), rng.uniform(900, 2000, 20)])
    _, jac = LENS.project(points)
    h = 1e-4
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        fd = (LENS.project(points + step)[0] - LENS.project(points - step)[0]) / 2 / h
        np.testing.assert_allclose(jac[:, :, axis], fd, rtol=1e-6, atol=1e-7)


# ---------------------------------------------------------------------------------------------- derivatives
def test_the_kinematics_orientation_rows_are_world_frame_rotations() -> None:
    """What the camera's θ-derivative assumes of `forward_kinematics(..., jacobian=True)`: its rows 3–5 are
    the small rotation ω in the world frame, R(θ + h eₖ) ≈ (I + h [ωₖ]×) R(θ)."""
    joints = sample_workspace(DESC, 4, seed=3)
    theta = DESC.parameters.nominal
    fk = forward_kinematics(DESC, joints, theta, jacobian=True)
    h = 1e-6
    for k in range(len(theta)):
        step = np.zeros_like(theta)
        step[k] = h
        plus, minus = (forward_kinematics(DESC, joints, theta + s).rotations for s in (step, -step))
        turned = matrix_to_rotvec_np(plus @ np.transpose(minus, (0, 2, 1))) / (2 * h)
        np.testing.assert_allclose(fk.jacobians[:, 3:, k], turned, atol=1e-6)


@pytest.mark.parametrize("mount", [Camera, ToolCamera], ids=["world", "tool"])
def test_the_camera_derivatives_match_finite_differences(mount: type[Camera]) -> None:
    """∂r/∂θ through the real forward kinematics (positions and rotations) and ∂r/∂u by its six unknowns, at a
    pose off the start (ω ≠ 0, so the rotation's left Jacobian matters)."""
    joints = sample_workspace(DESC, 6, seed=5)
    rng = np.random.default_rng(5)
    theta = DESC.parameters.nominal + rng.normal(0, 1e-3, len(DESC.parameters))
    fk = forward_kinematics(DESC, joints, theta, jacobian=True)
    camera_rotation = np.column_stack([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
    if mount is Camera:
        camera = Camera("c", LENS, (1500.0, 0.0, 200.0), tuple(matrix_to_rotvec_np(camera_rotation)))
        targets = MARKERS[np.arange(6) % 4]
    else:
        camera = ToolCamera("c", LENS, (40.0, -30.0, 20.0), (0.1, -0.05, 0.02))
        # A point 1 m in front of the camera in each pose: where a board's point would be seen.
        rc = camera.orientation(np.zeros(3))
        ahead = np.array(camera.position) + rc @ np.array([30.0, -20.0, 1000.0])
        targets = np.einsum("nij,j->ni", fk.rotations, ahead) + fk.positions
    values = np.column_stack([np.zeros(6), np.arange(6), targets, rng.uniform(500, 1500, (6, 2))])
    u = np.array([s.nominal for s in camera.unknowns]) + np.r_[rng.normal(0, 2, 3), rng.normal(0, 0.05, 3)]
    r, d_theta, d_u = camera.residuals(fk, u, values)
    assert r.shape == (6, 2) and np.all(np.isfinite(r))
    h = 1e-6
    for k in range(6):
        step = np.zeros(6)
        step[k] = h
        fd = (camera.residuals(fk, u + step, values)[0] - camera.residuals(fk, u - step, values)[0]) / 2 / h
        np.testing.assert_allclose(d_u[:, :, k], fd, rtol=1e-5, atol=1e-4)
    for k in range(len(theta)):
        step = np.zeros_like(theta)
        step[k] = h * DESC.parameters.scales[k]
        plus, minus = (forward_kinematics(DESC, joints, theta + s, jacobian=True) for s in (step, -step))
        fd = (camera.residuals(plus, u, values)[0] - camera.residuals(minus, u, values)[0]) / (2 * step[k])
        np.testing.assert_allclose(d_theta[:, :, k], fd, rtol=1e-5, atol=1e-3 / DESC.parameters.scales[k])


# ---------------------------------------------------------------------------------------------- identifiability
def _jacobian(campaign: CameraCampaign) -> tuple[np.ndarray, ReferenceProblem]:
    """The weighted Jacobian at the truth over every robot parameter and the camera's six unknowns."""
    rt = runtime_for(DESC)
    group = campaign.groups[0]
    assert isinstance(group.reference, Camera)
    rx, ry, rz = (float(v) for v in matrix_to_rotvec_np(campaign.rotation))
    x, y, z = (float(v) for v in campaign.position)
    camera = replace(group.reference, position=(x, y, z), rotation=(rx, ry, rz))
    groups = (replace(group, reference=camera),)
    problem = reference_problem(
        DESC, groups, noise=NoiseModel(), theta=campaign.truth, estimate=("base", "links", "tool"), runtime=rt
    )
    everything = ReferenceProblem(
        DESC, rt, groups, NoiseModel(), campaign.truth, np.arange(len(DESC.parameters)), problem.u_start,
        problem.u_scales,
    )  # fmt: skip
    start = everything.evaluate(np.zeros(everything.n_free))
    assert start is not None
    return start.jacobian, problem


def _rank(matrix: np.ndarray) -> int:
    s = np.linalg.svd(matrix / np.linalg.norm(matrix, axis=0), compute_uv=False)
    return int(np.sum(s > s[0] * 1e-8))


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_what_a_camera_can_identify() -> None:
    """A world camera's pose and the robot's base are one and the same unknown (moving both changes no pixel):
    the twelve columns have rank 6, so the base is held. A tool camera's pose and the tool transform are (only
    their product reaches the pixels), while its board, given in the world, sees the base."""
    n = len(DESC.parameters)
    base, tool = np.arange(DESC.slices["base"].start, DESC.slices["base"].stop), np.arange(n - 6, n)
    camera = np.arange(n, n + 6)
    world_jacobian, world = _jacobian(world_camera_campaign(DESC, 1))
    assert _rank(world_jacobian[:, np.r_[base, camera]]) == 6
    assert _rank(world_jacobian[:, np.r_[tool, camera]]) == 12  # markers on the tool: its frame is seen
    names = {DESC.parameters.names[i] for i in world.free}
    assert not names & ({f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")} | {"link1.theta", "link1.d"})
    assert {f"tool.{c}" for c in ("y", "rx", "ry", "rz")} <= names
    tool_jacobian, hand = _jacobian(tool_camera_campaign(DESC, 1))
    assert _rank(tool_jacobian[:, np.r_[tool, camera]]) == 6
    assert _rank(tool_jacobian[:, np.r_[base, camera]]) == 12
    names = {DESC.parameters.names[i] for i in hand.free}
    assert not names & {f"tool.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")}
    assert {"base.x", "base.y", "base.z", "base.rx", "base.ry"} <= names


# ---------------------------------------------------------------------------------------------- recovery
NOISE = NoiseModel(0.002, 1e-5)


def _pose_error(fit_values: np.ndarray, start: Camera, rotation: np.ndarray, position: np.ndarray) -> np.ndarray:
    """(position error, rotation error as a left rotation vector) of a fitted camera against the truth."""
    found = start.orientation(fit_values[3:6])
    return np.concatenate([fit_values[:3] - position, matrix_to_rotvec_np(found @ rotation.T)])


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_world_camera_calibrates_the_robot_and_finds_itself(seed: int) -> None:
    campaign = world_camera_campaign(DESC, seed, sigma_px=SIGMA_PX)
    fit = identify_references(DESC, campaign.groups, noise=NOISE)
    assert fit.solver.success and not fit.outliers
    assert fit.covariance.noise_consistent, (fit.covariance.variance_factor, fit.covariance.chi2_interval)
    assert {"base.x", "base.rz", "link1.theta", "link1.d"} <= set(fit.unidentifiable) and "base" in fit.frame
    # The camera's pose, found from no guess at all, within its standard errors of the truth (the truth is in
    # the gauge the camera leaves free).
    camera = fit.references[0]
    assert isinstance(camera.reference, Camera)
    error = _pose_error(camera.values, camera.reference, campaign.rotation, campaign.position)
    assert np.all(np.abs(error) < 4.5 * camera.std_errors), (error, camera.std_errors)
    assert camera.rms_residual_mm < 2 * SIGMA_PX  # in the camera's unit: px
    # The TCP on fresh poses within thrice the bound the fit predicts for itself, with no alignment, far below
    # the nominal model's error. (Thrice: a few directions dominate the TCP's error, so its ratio to the bound
    # spreads like a χ² of few degrees of freedom, 0.4–2.2 over ten seeds; the benchmark holds the median.)
    fresh = sample_workspace(DESC, 300, seed=999)
    true_p = forward_kinematics(DESC, fresh, campaign.truth).positions
    error_p = forward_kinematics(DESC, fresh, fit.parameters).positions - true_p
    after = float(np.sqrt(np.mean(np.sum(error_p**2, axis=1))))
    bound = predicted_rms(DESC, fit, fresh)
    before = aligned_rms(forward_kinematics(DESC, fresh).positions, true_p)
    assert after < 3.0 * bound and after < 0.15 * before, (after, bound, before)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_world_camera_recovers_each_parameter_within_its_errors() -> None:
    """Parameter by parameter: the truth in the full gauge of these records (every parameter the fit holds at
    its nominal value, so that none is absorbed by another), the same poses imaged again; every estimated
    parameter within its standard errors, and their joint Mahalanobis distance a χ² of as many degrees."""
    campaign = world_camera_campaign(DESC, 5, sigma_px=SIGMA_PX)
    held = identify_references(DESC, campaign.groups, noise=NOISE).unidentifiable
    truth = campaign.truth.copy()
    index = list(DESC.parameters.indices(held))
    truth[index] = DESC.parameters.nominal[index]
    joints = np.array([image["joints"] for image in campaign.images])
    records, _ = world_images(DESC, truth, joints, np.random.default_rng(5), sigma_px=SIGMA_PX)
    fit = identify_references(DESC, read_images(WORLD_CAMERA, records), noise=NOISE)
    assert fit.unidentifiable == held and fit.covariance.noise_consistent
    est = np.array(fit.estimated)
    error = fit.parameters[est] - truth[est]
    assert np.all(np.abs(error) < 4.5 * fit.std_errors[est]), dict(
        zip([DESC.parameters.names[i] for i in est], (error / fit.std_errors[est]).round(1), strict=True)
    )
    distance = float(error @ np.linalg.solve(fit.parameter_covariance, error))
    assert distance < scipy.stats.chi2.ppf(0.999, est.size), (distance, est.size)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_camera_on_the_tool_finds_the_hand_eye_and_the_base() -> None:
    """Hand-eye: the camera's pose in the tool frame, with the robot's base in the board's frame. The constant
    transform after the last joint (link 6's constants, the tool) is held, since only its product with the
    hand-eye is seen: the truth is in that gauge, and the camera's frame is judged on fresh poses."""
    campaign = tool_camera_campaign(DESC, 2, sigma_px=SIGMA_PX)
    fit = identify_references(DESC, campaign.groups, noise=NOISE)
    assert fit.solver.success and fit.covariance.noise_consistent, fit.covariance.variance_factor
    assert {f"tool.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")} <= set(fit.unidentifiable)
    assert not {"base.x", "base.y", "base.z"} & set(fit.unidentifiable)
    camera = fit.references[0]
    assert isinstance(camera.reference, ToolCamera)
    error = _pose_error(camera.values, camera.reference, campaign.rotation, campaign.position)
    assert np.all(np.abs(error) < 4.5 * camera.std_errors), (error, camera.std_errors)
    fresh = sample_workspace(DESC, 200, seed=998)
    true_fk, fit_fk = (forward_kinematics(DESC, fresh, t) for t in (campaign.truth, fit.parameters))
    true_cam = true_fk.positions + true_fk.rotations @ campaign.position
    found_cam = fit_fk.positions + fit_fk.rotations @ camera.values[:3]
    rms = float(np.sqrt(np.mean(np.sum((found_cam - true_cam) ** 2, axis=1))))
    assert rms < 0.02, rms  # mm: from errors of tenths of a millimetre to some µm


# ---------------------------------------------------------------------------------------------- slips
def _world() -> CameraCampaign:
    return world_camera_campaign(DESC, 4, sigma_px=SIGMA_PX)


def _with(images: list[dict[str, Any]], index: int, **changes: Any) -> list[dict[str, Any]]:
    out = [dict(image) for image in images]
    out[index] = {**out[index], **changes}
    return out


def _cameras(**changes: Any) -> dict[str, dict[str, Any]]:
    return {"c1": {**INTRINSICS, "mount": "world", **changes}}


def test_swapped_pixels_are_named() -> None:
    images = _world().images
    swapped = [{**i, "points": [{**p, "pixel": p["pixel"][::-1]} for p in i["points"]]} for i in images]
    with pytest.raises(InvalidInput, match=r"look like \(v, u\)") as refused:
        identify_references(DESC, read_images(_cameras(), swapped), noise=NOISE)
    assert refused.value.reason == "pixel_order"


def test_a_focal_length_in_mm_is_named() -> None:
    with pytest.raises(InvalidInput, match="fx = 12 is not a focal length in pixels") as refused:
        read_images(_cameras(fx=12.0, fy=12.0), _world().images)
    assert refused.value.reason == "focal_unit" and refused.value.field == "cameras.c1.fx"
    with pytest.raises(InvalidInput, match="fx / fy") as refused:
        read_images(_cameras(fy=500.0), _world().images)


def test_targets_in_metres_fit_no_projection() -> None:
    images = [
        {**i, "points": [{**p, "target_mm": [v / 1000 for v in p["target_mm"]]} for p in i["points"]]}
        for i in _world().images
    ]
    with pytest.raises(InvalidInput, match="no pose of this camera projects the points") as refused:
        identify_references(DESC, read_images(_cameras(), images), noise=NOISE)
    assert refused.value.reason == "projection_misfit"


def test_a_camera_that_sees_nothing_or_is_not_described_is_named() -> None:
    images = _world().images
    with pytest.raises(InvalidInput, match=r"image 3 .* sees no point") as refused:
        read_images(_cameras(), _with(images, 3, points=[]))
    assert refused.value.reason == "camera_sees_nothing" and refused.value.field == "measurements[3].points"
    with pytest.raises(InvalidInput, match="camera 'c2', which is not described") as refused:
        read_images(_cameras(), _with(images, 5, camera="c2"))
    assert refused.value.reason == "unknown_camera" and refused.value.allowed == ["c1"]
    with pytest.raises(InvalidInput, match="mount"):
        read_images(_cameras(mount="ceiling"), images)
    ragged = [{**p, "target_mm": p["target_mm"][:2]} for p in images[2]["points"]]
    with pytest.raises(InvalidInput, match="each point is") as refused:
        read_images(_cameras(), _with(images, 2, points=ragged))
    assert refused.value.field == "measurements[2].points"
    group = read_images(_cameras(), images)[0]
    with pytest.raises(InvalidInput, match="give each record's σ in px"):
        identify_references(DESC, (replace(group, sigma_mm=None),), noise=NOISE)
    short = read_images(_cameras(), images[:1])
    with pytest.raises(TooFewMeasurements, match="image 'c1' has 4 records"):
        identify_references(DESC, short, noise=NOISE)


def test_a_point_behind_the_camera_is_named() -> None:
    campaign = _world()
    images = campaign.images
    # Image 6's third point: a target (tool frame) that puts it half a metre behind the camera.
    q = np.array(images[6]["joints"])
    fk = forward_kinematics(DESC, q[None, :])
    behind = fk.rotations[0].T @ (campaign.position + np.array([500.0, 30.0, 0.0]) - fk.positions[0])
    points = [dict(p) for p in images[6]["points"]]
    points[2] = {**points[2], "target_mm": behind.tolist()}
    with pytest.raises(InvalidInput, match="image 6, point 2 is behind the camera") as refused:
        identify_references(DESC, read_images(_cameras(), _with(images, 6, points=points)), noise=NOISE)
    assert refused.value.reason == "behind_camera"


def test_a_misdetected_marker_is_left_out_and_its_image_kept() -> None:
    campaign = _world()
    images = campaign.images
    points = [dict(p) for p in images[9]["points"]]
    points[1] = {**points[1], "pixel": [points[1]["pixel"][0] + 4.0, points[1]["pixel"][1]]}  # 40 σ
    groups = read_images(_cameras(), _with(images, 9, points=points))
    fit = identify_references(DESC, groups, noise=NOISE)
    assert [(o.reference, o.excluded) for o in fit.outliers] == [("c1", True)]
    record = fit.outliers[0].record
    assert groups[0].values[record, :2].tolist() == [9.0, 1.0]  # image 9, point 1: named by the record's values
    assert fit.references[0].records == groups[0].size - 1 and fit.covariance.noise_consistent
