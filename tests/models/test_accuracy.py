"""Validation of a version on a simulated robot whose truth is known: ISO 9283 cube, 30 cycles, known noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import forward_kinematics, iwr
from models.campaign import Campaign
from models.evaluation.accuracy import CubePoses, evaluate, iso_cube_poses
from models.identification.registration import rigid_fit
from models.noise import NoiseModel
from models.simulation import SimulatedRobot, measure, perturbed_robot

DESC = iwr()
SIGMA = 0.025
CYCLES = 30
# E|e| and sd|e| of an isotropic 3-D Gaussian error: σ·2√2/√π and σ·√(3 − 8/π).
EXPECTED_RP = SIGMA * (2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi))


@pytest.fixture(scope="module")
def setting() -> tuple[SimulatedRobot, CubePoses, Campaign]:
    sim = perturbed_robot(DESC, seed=61)
    cube = iso_cube_poses(DESC, DESC.parameters.nominal)
    # ISO 9283 order: each cycle visits P1…P5; the noise of every visit is independent.
    joints = np.tile(cube.joints, (CYCLES, 1))
    campaign = measure(sim, joints, NoiseModel(SIGMA, math.radians(0.005)), seed=62)
    return sim, cube, campaign


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_the_cube_poses_put_the_tcp_on_the_cube_points(setting: tuple[SimulatedRobot, CubePoses, Campaign]) -> None:
    _, cube, _ = setting
    fk = forward_kinematics(DESC, cube.joints, DESC.parameters.nominal)
    np.testing.assert_allclose(fk.positions, cube.cube.points, atol=1e-6)
    assert cube.cube.edge_mm > 50


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_true_parameters_have_only_the_noise_left(setting: tuple[SimulatedRobot, CubePoses, Campaign]) -> None:
    sim, _, campaign = setting
    report = evaluate(DESC, sim.truth, campaign)
    assert len(report.iso_poses) == 5 and all(len(p.records) == CYCLES for p in report.iso_poses)
    for pose in report.iso_poses:
        # The barycentre of 30 cycles sits within a few σ/√30 of the truth.
        assert pose.characteristics.accuracy_mm < 4 * SIGMA / math.sqrt(CYCLES)
        assert pose.characteristics.repeatability_mm == pytest.approx(EXPECTED_RP, rel=0.35)
    assert report.rms_mm == pytest.approx(SIGMA * math.sqrt(3), rel=0.15)
    assert len(report.iso_distances) == 4
    assert all(abs(d.characteristics.accuracy_mm) < 4 * SIGMA for d in report.iso_distances)


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_the_nominal_model_shows_its_geometric_error(setting: tuple[SimulatedRobot, CubePoses, Campaign]) -> None:
    sim, cube, campaign = setting
    report = evaluate(DESC, DESC.parameters.nominal, campaign, register=True)
    # Independent truth: the true TCP against the nominal one registered onto it without noise.
    truth = forward_kinematics(DESC, cube.joints, sim.truth).positions
    registration = rigid_fit(
        forward_kinematics(DESC, campaign.joints, DESC.parameters.nominal).positions,
        forward_kinematics(DESC, campaign.joints, sim.truth).positions,
    )
    expected = np.linalg.norm(truth - registration.apply(cube.cube.points), axis=1)
    got = np.array([p.characteristics.accuracy_mm for p in report.iso_poses])
    np.testing.assert_allclose(got, expected, atol=4 * SIGMA / math.sqrt(CYCLES) + 1e-3)
    # Registered on five points of a 10 cm cube, the rigid fit absorbs most of the geometric error; what is
    # left still stands well above what the true parameters leave.
    calibrated = evaluate(DESC, sim.truth, campaign)
    assert got.max() > 2 * max(p.characteristics.accuracy_mm for p in calibrated.iso_poses)
    assert report.registered and not calibrated.registered
