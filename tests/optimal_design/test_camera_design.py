"""Pose design for a camera's images: a candidate pose is one image (every point it would see, none it would
not), its block the rows the fit would stack for it, and designed images predict less than random ones and
reach what they predict in simulated fits."""

from __future__ import annotations

import numpy as np
import pytest

from harness.camera import (
    INTRINSICS,
    MARKERS,
    WORLD_CAMERA,
    WORLD_CAMERA_POSITION,
    WORLD_CAMERA_ROTATION,
    camera_gauge_truth,
    project,
    world_images,
)
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.engine.runtime import runtime_for
from models.identification.options import IdentificationOptions
from models.identification.reference_fit import identify_references, reference_problem
from models.measurements.camera import Camera, Intrinsics, read_images
from models.measurements.references import ReferenceRecords
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np
from optimal_design.references import camera_candidates, design_reference_records, reference_information

DESC = ur5_like()
NOISE = NoiseModel(0.002, 1e-5)
LENS = Intrinsics(
    INTRINSICS["fx"], INTRINSICS["fy"], INTRINSICS["cx"], INTRINSICS["cy"], tuple(INTRINSICS["distortion"])
)
RX, RY, RZ = (float(v) for v in matrix_to_rotvec_np(WORLD_CAMERA_ROTATION))
X, Y, Z = (float(v) for v in WORLD_CAMERA_POSITION)
CAMERA = Camera("c1", LENS, (X, Y, Z), (RX, RY, RZ))


def _candidates(n: int = 300, seed: int = 42) -> ReferenceRecords:
    return camera_candidates(DESC, CAMERA, sample_workspace(DESC, n, seed=seed), MARKERS, sigma_px=0.1)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_candidate_image_is_the_points_it_would_see() -> None:
    joints = sample_workspace(DESC, 300, seed=42)
    candidates = camera_candidates(DESC, CAMERA, joints, MARKERS, sigma_px=0.1)
    # Independently: the markers through the nominal model and the harness's numpy projection, kept where they
    # are in front of the camera and on its 2048 × 1536 image.
    fk = forward_kinematics(DESC, joints)
    world = np.einsum("nij,mj->nmi", fk.rotations, MARKERS) + fk.positions[:, None, :]
    cam = (world - WORLD_CAMERA_POSITION) @ WORLD_CAMERA_ROTATION
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = project(cam.reshape(-1, 3), INTRINSICS).reshape(300, 4, 2)
    u, v = pixels[..., 0], pixels[..., 1]
    seen = (cam[..., 2] > 0) & (u >= 0) & (u <= 2048) & (v >= 0) & (v <= 1536)
    assert 0 < seen.sum() < seen.size  # some poses show the markers, some do not
    assert candidates.size == seen.sum()
    np.testing.assert_array_equal(candidates.values[:, :2], np.argwhere(seen))
    np.testing.assert_allclose(candidates.values[:, 5:], pixels[seen], atol=1e-9)
    # One candidate per pose that sees anything; its block is the fit's rows of its points, stacked.
    info = reference_information(DESC, (candidates,), noise=NOISE)
    images = np.flatnonzero(seen.any(axis=1))
    assert info.size == images.size and info.rows == 2 * 4
    np.testing.assert_array_equal(info.joints, joints[images])
    problem = reference_problem(
        DESC, (candidates,), noise=NOISE, theta=DESC.parameters.nominal, estimate=IdentificationOptions().estimate,
        runtime=runtime_for(DESC),
    )  # fmt: skip
    rows = problem.evaluate(np.zeros(problem.n_free))
    assert rows is not None
    first = 0
    for k, image in enumerate(images[:20]):
        count = int(seen[image].sum())
        block = rows.jacobian[2 * first : 2 * (first + count)]
        np.testing.assert_allclose(info.blocks[k, : 2 * count], block, rtol=1e-12, atol=1e-12)
        assert not info.blocks[k, 2 * count :].any()
        first += count


def _fit_error(joints: np.ndarray, seed: int) -> float:
    """RMS TCP error on fresh poses of a fit of the images taken at `joints`, simulated."""
    truth = camera_gauge_truth(DESC, seed)
    records, _ = world_images(DESC, truth, joints, np.random.default_rng(seed), sigma_px=0.1)
    fit = identify_references(DESC, read_images(WORLD_CAMERA, records), noise=NOISE)
    fresh = sample_workspace(DESC, 300, seed=999)
    error = forward_kinematics(DESC, fresh, fit.parameters).positions - forward_kinematics(DESC, fresh, truth).positions
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))


@pytest.mark.slow  # a design over ~480 candidate images and five simulated fits: a few seconds
def test_designed_images_predict_and_reach_less_than_random_ones() -> None:
    candidates = _candidates(600)
    design = design_reference_records(DESC, (candidates,), 20, "I", noise=NOISE, seed=1)
    designed = design.metrics["predicted_rms_tcp_mm"]
    random = design.random_baseline["predicted_rms_tcp_mm"]
    assert designed <= 0.8 * random, (designed, random)
    # Simulated fits of those 20 images reach what the design predicts (median over five seeds: one fit's
    # error spreads like a χ² of few degrees of freedom about it).
    reached = np.median([_fit_error(design.joints, s) for s in (11, 12, 13, 14, 15)])
    assert 0.5 * designed <= reached <= 1.5 * designed, (reached, designed)
