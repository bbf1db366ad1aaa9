"""Campaigns IPOPT alone cannot close: 40 position-only records of an industrial 6R arm on one straight line.

The records of a linear move (the tool's orientation held, as a robot program's `MoveL` does) leave the
column-scaled Jacobian at condition ~4e8–6e8: IPOPT's Gauss–Newton Hessian is then at ~1e17 and IPOPT stops
("Error_In_Step_Computation"). The trust-region finish (`models/identification/trust_region.py`) converges
there; the yardstick is scipy's `least_squares` fitting an independent numpy model of the same arm
(`industrial.py`) to the same records, both judged on 300 fresh records of the same line.
"""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, forward_kinematics
from models.identification import identify
from models.identification.trust_region import describe_unobservable
from models.simulation import measure, perturbed_robot
from tests.identification.industrial import (
    fk,
    irb2400_like,
    reference_fit,
    reference_nominal,
    register,
    straight_line_joints,
)

NOISE = NoiseModel(position_mm=0.03)
START = np.radians([-20.0, 10.0, 20.0, 30.0, 50.0, -40.0])


def _line(seed: int) -> tuple[np.ndarray, np.ndarray]:
    x0 = reference_nominal()
    rng = np.random.default_rng(seed)
    p0 = fk(x0, START[None, :])[0]
    d = np.array([0.0, 1.0, 0.3]) / np.hypot(1.0, 0.3)
    a, b = p0 - 300.0 * d, p0 + 300.0 * d
    fit = straight_line_joints(a, b, 40, x=x0, seed_joints=START, rng=rng)
    held = straight_line_joints(a, b, 300, x=x0, seed_joints=START, rng=rng)
    return fit, held


def test_numpy_model_is_the_products_model_at_nominal() -> None:
    desc = irb2400_like()
    q = np.random.default_rng(0).uniform(-2.0, 2.0, (20, 6))
    mine = forward_kinematics(desc, q, desc.parameters.nominal).positions
    assert np.abs(mine - fk(reference_nominal(), q)).max() < 1e-9


# Seed 1: the closest of seeds 0-5 to the reference (1.02; 1.01 on 5, 0.50-1.00 on the others); the others cost
# ~5 s of CPU each for a margin this one already shows.
@pytest.mark.slow  # ~3 s: two reference fits by finite differences
@pytest.mark.parametrize("seed", [1])
def test_a_straight_line_campaign_converges_near_an_independent_fit(seed: int) -> None:
    desc = irb2400_like()
    fit_q, held_q = _line(seed)
    sim = perturbed_robot(desc, seed=seed)
    campaign = measure(sim, fit_q, NOISE, seed=300 + seed, position_only=True)
    result = identify(desc, campaign, noise=NOISE)
    assert result.succeeded, result.reason
    assert result.condition_number > 1e8  # the case: IPOPT alone stops here
    assert result.solver.name == "ipopt+trust-region"
    truth = forward_kinematics(desc, held_q, sim.truth).positions
    ours = np.sqrt(np.mean(np.sum((forward_kinematics(desc, held_q, result.parameters).positions - truth) ** 2, 1)))
    x = reference_fit(fit_q, campaign.positions, register(fit_q, campaign.positions, reference_nominal()))
    theirs = np.sqrt(np.mean(np.sum((fk(x, held_q) - truth) ** 2, 1)))
    # Measured 1.02 and 1.01 (seeds 1, 5; 0.50-1.00 on seeds 0, 2-4), the directions the records do not see put
    # back to their start (before that: 1.10 and 1.18, where Levenberg–Marquardt's damping left them).
    assert ours <= 1.05 * theirs
    assert ours < 2.5 * NOISE.position_mm


def test_the_unobservable_directions_are_named_with_the_parameters_to_hold() -> None:
    # A Jacobian whose third column is the sum of the first two plus 1e-6 σ: one direction, (1, 1, -1)/√3.
    rng = np.random.default_rng(1)
    a = rng.normal(size=(30, 2))
    j = np.column_stack([a, a.sum(axis=1) + 1e-6 * rng.normal(size=30)])
    sentence, hold = describe_unobservable(j, ("link1.d", "link2.d", "tool.z"))
    assert sentence.startswith("1 direction(s)")
    for name in ("link1.d", "link2.d", "tool.z"):
        assert name in sentence
    assert len(hold) == 1 and hold[0] in ("link1.d", "link2.d", "tool.z")
    assert describe_unobservable(a, ("x", "y")) == ("", ())


@pytest.mark.slow  # ~2 s: a line campaign and a box campaign, each with 300 fresh records
def test_the_prediction_holds_in_the_measured_region_and_flags_the_rest() -> None:
    desc = irb2400_like()
    fit_q, held_q = _line(1)
    box_center = np.radians([-20.0, 20.0, 30.0, 150.0, 60.0, -140.0])
    half = np.radians([20.0, 10.0, 20.0, 5.0, 15.0, 15.0])
    rng = np.random.default_rng(11)
    box = box_center + rng.uniform(-half, half, (40, 6)), box_center + rng.uniform(-half, half, (300, 6))
    for seed, (fit, held) in ((1, (fit_q, held_q)), (2, box)):
        sim = perturbed_robot(desc, seed=seed)
        result = identify(desc, measure(sim, fit, NOISE, seed=400 + seed, position_only=True), noise=NOISE)
        assert result.succeeded, result.reason
        truth = forward_kinematics(desc, held, sim.truth).positions
        errors = forward_kinematics(desc, held, result.parameters).positions - truth
        measured = float(np.sqrt(np.mean(np.sum(errors**2, axis=1))))
        predicted = result.predicted_accuracy
        # Inside the measured region: within 2× of the error measured on fresh records there.
        assert 0.5 < predicted.region_rms_position_mm / measured < 2.0
        # The workspace-wide figure is far above (the directions these records do not see): said, not silent.
        assert predicted.rms_position_mm > 10 * predicted.region_rms_position_mm
        assert predicted.extrapolation is not None and "extrapolation" in predicted.extrapolation
        assert predicted.extrapolation in result.notes
