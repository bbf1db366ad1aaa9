"""The default calibration keeps gross errors out by itself (robust "auto"), and says which poses it dropped."""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, iwr, sample_workspace
from models.campaign import Campaign
from models.identification import IdentificationOptions, RobustLoss, identify
from models.simulation import SimulatedRobot, measure, perturbed_robot
from tests.identification.truth import rms_position_error

DESC = iwr()
NOISE = NoiseModel()
CHECK = sample_workspace(DESC, 100, seed=99)


def _with_blunders(campaign: Campaign, poses: list[int], seed: int) -> Campaign:
    rng = np.random.default_rng(seed)
    positions = campaign.positions.copy()
    directions = rng.normal(size=(len(poses), 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    positions[poses] += directions * rng.uniform(2.0, 3.0, size=(len(poses), 1))
    return Campaign(campaign.joints, positions, campaign.quaternions)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_three_blunders_among_sixty_poses_cost_at_most_thirty_percent(seed: int) -> None:
    sim: SimulatedRobot = perturbed_robot(DESC, seed=seed)
    clean = measure(sim, sample_workspace(DESC, 60, seed=seed + 10), NOISE, seed=seed + 20)
    blunders = [5, 23, 41]
    dirty = _with_blunders(clean, blunders, seed)
    reference = identify(DESC, clean, noise=NOISE)
    default = identify(DESC, dirty, noise=NOISE)  # nobody asked for robustness
    assert default.succeeded and default.noise_consistent, default.notes
    excluded = [o.pose for o in default.outliers if o.excluded]
    assert sorted(excluded) == blunders
    statistics = [o.statistic for o in default.outliers]
    assert statistics == sorted(statistics, reverse=True)  # worst first
    assert all(2.0 <= o.position_mm <= 3.5 for o in default.outliers)  # named with the residual it had
    error = rms_position_error(DESC, default.parameters, sim, CHECK)
    assert error <= 1.3 * rms_position_error(DESC, reference.parameters, sim, CHECK)
    # Asking for plain least squares stays possible, and shows what the default avoided.
    plain = identify(DESC, dirty, noise=NOISE, options=IdentificationOptions(robust=RobustLoss.NONE))
    assert not plain.noise_consistent and not any(o.excluded for o in plain.outliers)
    assert rms_position_error(DESC, plain.parameters, sim, CHECK) > 2 * error


def test_one_blunder_is_one_outlier_not_twenty_seven() -> None:
    sim = perturbed_robot(DESC, seed=7)
    dirty = _with_blunders(measure(sim, sample_workspace(DESC, 40, seed=8), NOISE, seed=9), [12], seed=10)
    plain = identify(DESC, dirty, noise=NOISE, options=IdentificationOptions(robust=RobustLoss.NONE))
    default = identify(DESC, dirty, noise=NOISE)
    assert len(plain.outliers) > 3  # least squares smears the blunder
    assert [o.pose for o in default.outliers] == [12] and default.outliers[0].excluded


def test_a_clean_campaign_takes_the_plain_path() -> None:
    """Without gross errors the default is plain least squares: one solve, identical numbers."""
    sim = perturbed_robot(DESC, seed=11)
    clean = measure(sim, sample_workspace(DESC, 60, seed=12), NOISE, seed=13)
    default = identify(DESC, clean, noise=NOISE)
    plain = identify(DESC, clean, noise=NOISE, options=IdentificationOptions(robust=RobustLoss.NONE))
    assert default.outliers == () and np.array_equal(default.parameters, plain.parameters)


def test_records_are_weighted_by_their_own_uncertainty() -> None:
    """Half the points measured 6× worse (far from the tracker): stating each record's σ keeps the fit honest
    (variance factor ≈ 1) and more accurate than one σ for all."""
    sim = perturbed_robot(DESC, seed=14)
    joints = sample_workspace(DESC, 80, seed=15)
    fine = measure(sim, joints, NoiseModel(0.02, NOISE.orientation_rad), seed=16)
    coarse = measure(sim, joints, NoiseModel(0.12, NOISE.orientation_rad), seed=17)
    worse = np.arange(80) % 2 == 1
    positions = np.where(worse[:, None], coarse.positions, fine.positions)
    sigma = np.where(worse, 0.12, 0.02)
    stated = Campaign(fine.joints, positions, fine.quaternions, sigma)
    single = Campaign(fine.joints, positions, fine.quaternions)
    noise = NoiseModel(0.02, NOISE.orientation_rad)
    weighted = identify(DESC, stated, noise=noise)
    unweighted = identify(DESC, single, noise=noise, options=IdentificationOptions(robust=RobustLoss.NONE))
    assert weighted.noise_consistent and not unweighted.noise_consistent
    assert 0.7 < weighted.variance_factor < 1.4
    errors = [rms_position_error(DESC, r.parameters, sim, CHECK) for r in (weighted, unweighted)]
    assert errors[0] < errors[1]
