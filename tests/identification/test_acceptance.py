"""Acceptance by simulation: a perturbed IWR with known parameters, measured, identified, validated."""

from __future__ import annotations

from typing import cast

import numpy as np
import pytest
import scipy.stats

from models import NoiseModel, RobotDescription, sample_workspace
from models.identification import IdentificationOptions, RobustLoss, identify
from models.simulation import SimulatedRobot, measure, perturbed_robot
from tests.identification.truth import cramer_rao_rms, nominal_in_true_frame, rms_position_error

NOISE = NoiseModel()


@pytest.fixture(scope="module")
def sim(desc: RobotDescription) -> SimulatedRobot:
    return perturbed_robot(desc, seed=1)


@pytest.fixture(scope="module")
def check_joints(desc: RobotDescription) -> np.ndarray:
    return sample_workspace(desc, 100, seed=4242)


@pytest.mark.parametrize(("count", "position_only", "identifiable"), [(60, False, 54), (80, True, 51)])
def test_calibrated_model_reaches_the_cramer_rao_accuracy(
    desc: RobotDescription,
    sim: SimulatedRobot,
    check_joints: np.ndarray,
    count: int,
    position_only: bool,
    identifiable: int,
) -> None:
    joints = sample_workspace(desc, count, seed=11)
    result = identify(desc, measure(sim, joints, NOISE, seed=12, position_only=position_only), noise=NOISE)
    assert result.succeeded, result.reason
    assert len(result.estimated) == identifiable

    error = rms_position_error(desc, result.parameters, sim, check_joints)
    bound = cramer_rao_rms(
        desc, sim, joints, check_joints, np.array(result.estimated), NOISE, position_only=position_only
    )
    before = rms_position_error(desc, nominal_in_true_frame(desc, sim), sim, check_joints)
    assert error <= 1.3 * bound
    assert before / error >= 50
    # The reported prediction is the same quantity from the a-posteriori covariance at the estimate.
    assert result.predicted_accuracy.rms_position_mm == pytest.approx(bound, rel=0.3)
    assert result.noise_consistent
    assert result.residuals_after.rms_mm < 0.1 * result.residuals_before.rms_mm


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("loss", [RobustLoss.AUTO, RobustLoss.HUBER, RobustLoss.SOFT_L1])
def test_robust_fit_flags_and_survives_a_broken_beam(
    desc: RobotDescription, sim: SimulatedRobot, check_joints: np.ndarray, loss: RobustLoss
) -> None:
    joints = sample_workspace(desc, 60, seed=21)
    clean = measure(sim, joints, NOISE, seed=22)
    rng = np.random.default_rng(23)
    broken = np.array([7, 30, 51])
    positions = clean.positions.copy()
    directions = rng.normal(size=(3, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    positions[broken] += directions * rng.uniform(2.0, 3.0, size=(3, 1))
    campaign = type(clean)(clean.joints, positions, clean.quaternions)

    robust = identify(desc, campaign, noise=NOISE, options=IdentificationOptions(robust=loss))
    assert robust.succeeded, robust.reason
    assert sorted(o.pose for o in robust.outliers) == broken.tolist()
    assert all(o.excluded and 2.0 <= o.position_mm <= 3.5 for o in robust.outliers)
    keep = np.setdiff1d(np.arange(60), broken)
    bound = cramer_rao_rms(
        desc, sim, joints[keep], check_joints, np.array(robust.estimated), NOISE, position_only=False
    )
    assert rms_position_error(desc, robust.parameters, sim, check_joints) <= 2 * bound

    # Plain least squares (robust "none") flags the same data as inconsistent and its estimate is visibly worse.
    plain = identify(desc, campaign, noise=NOISE, options=IdentificationOptions(robust=RobustLoss.NONE))
    assert not plain.noise_consistent
    assert rms_position_error(desc, plain.parameters, sim, check_joints) > 2 * bound


@pytest.mark.slow  # Monte Carlo: 25 noise draws, a calibration each
def test_reported_covariance_is_honest(desc: RobotDescription, sim: SimulatedRobot) -> None:
    """Over noise draws, (θ̂ − θ*)ᵀ Σ⁻¹ (θ̂ − θ*) follows χ² with as many degrees of freedom as parameters.

    θ* is the estimate from noise-free data: the identifiable combination of the true parameters (the rest are
    held at nominal values, so the raw truth is not what the estimate converges to).
    """
    joints = sample_workspace(desc, 60, seed=31)
    exact = measure(sim, joints, NoiseModel(1e-12, 1e-12), seed=0)
    star = identify(desc, exact, noise=NOISE)
    free = np.array(star.estimated)
    draws = 25
    stats = []
    for k in range(draws):
        result = identify(desc, measure(sim, joints, NOISE, seed=1000 + k), noise=NOISE)
        assert result.estimated == star.estimated
        d = (result.parameters - star.parameters)[free]
        stats.append(float(d @ np.linalg.solve(result.covariance, d)))
    total, dof = sum(stats), draws * free.size
    # scipy-stubs type ppf of any array-like as float | array; of a list it is an array
    low, high = cast(np.ndarray, scipy.stats.chi2.ppf([0.001, 0.999], dof))
    assert low <= total <= high, (total / draws, free.size)
