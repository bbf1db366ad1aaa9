"""Per-pose predictions judged against the measured region (`models.identification.pose_accuracy`).

Truth: a perturbed IRB 2400-sized arm whose parameters are known, measured position-only (σ 0.03 mm) in a box of
joint space or on a straight line; every prediction is compared with the error the calibrated model really makes
at fresh poses, inside the region and away from it.
"""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, forward_kinematics
from models.engine.runtime import default_registry
from models.identification import identify
from models.identification.pose_accuracy import PoseAccuracy, measured_region, pose_accuracy
from models.simulation import measure, perturbed_robot
from tests.identification.industrial import fk, irb2400_like, reference_nominal, straight_line_joints

NOISE = NoiseModel(position_mm=0.03)
BOX_CENTER = np.radians([-20.0, 20.0, 30.0, 150.0, 60.0, -140.0])
BOX_HALF = np.radians([20.0, 10.0, 20.0, 5.0, 15.0, 15.0])


def _judged(fit_q: np.ndarray, poses: np.ndarray, seed: int) -> tuple[np.ndarray, PoseAccuracy]:
    """Calibrate from `fit_q` on a perturbed truth; the true TCP error at `poses` and the per-pose predictions."""
    desc = irb2400_like()
    sim = perturbed_robot(desc, seed=seed)
    result = identify(desc, measure(sim, fit_q, NOISE, seed=500 + seed, position_only=True), noise=NOISE)
    assert result.succeeded, result.reason
    free = np.asarray(result.estimated, dtype=np.intp)
    cov = result.prediction_covariance
    assert cov is not None
    runtime = default_registry().runtime(desc)
    region = measured_region(desc, fit_q, result.parameters, free, cov, runtime=runtime)
    found = pose_accuracy(desc, poses, result.parameters, free, cov, region=region, runtime=runtime)
    truth = forward_kinematics(desc, poses, sim.truth).positions
    error = np.linalg.norm(forward_kinematics(desc, poses, result.parameters).positions - truth, axis=1)
    return error, found


def _held_inside_flagged_away(
    fit_q: np.ndarray, inside: np.ndarray, away: np.ndarray, seed: int
) -> tuple[np.ndarray, PoseAccuracy]:
    """`_judged` at the `inside` poses, then the `away` ones. Inside: (almost) never flagged, and the RMS
    prediction within 2× the RMS error the model really makes. Away: every pose flagged."""
    error, found = _judged(fit_q, np.vstack([inside, away]), seed=seed)
    n = len(inside)
    flags = np.array([why is not None for why in found.extrapolation])
    assert flags[:n].mean() < 0.05
    ratio = np.sqrt(np.mean(found.position_mm[:n] ** 2)) / np.sqrt(np.mean(error[:n] ** 2))
    assert 0.5 < ratio < 2.0, ratio
    assert flags[n:].all()
    return error, found


@pytest.mark.slow  # ~1 s: a calibration and 400 predictions
def test_inside_a_measured_box_the_prediction_holds_and_outside_every_pose_is_flagged() -> None:
    rng = np.random.default_rng(11)
    fit_q = BOX_CENTER + rng.uniform(-BOX_HALF, BOX_HALF, (40, 6))
    inside = BOX_CENTER + rng.uniform(-0.9 * BOX_HALF, 0.9 * BOX_HALF, (300, 6))
    # Away from the box: joint 4 turned half a turn, the others anywhere in the box.
    away = inside[:100] + np.radians([0.0, 0.0, 0.0, -150.0, 0.0, 0.0])
    _, found = _held_inside_flagged_away(fit_q, inside, away, seed=2)
    # Away: naming the joint that left its measured span with the span in degrees.
    assert all("q4" in str(why) and "outside the measured" in str(why) for why in found.extrapolation[300:])
    assert np.all(found.distance[300:] > 0.15)  # q4 turned 140-160° of its 720° range


@pytest.mark.slow  # ~2 s: a line campaign's calibration (the trust-region finish) and 400 predictions
def test_a_line_campaign_predicts_its_line_and_calls_the_box_around_it_extrapolation() -> None:
    x0 = reference_nominal()
    start = np.radians([-20.0, 10.0, 20.0, 30.0, 50.0, -40.0])
    rng = np.random.default_rng(1)
    p0 = fk(x0, start[None, :])[0]
    d = np.array([0.0, 1.0, 0.3]) / np.hypot(1.0, 0.3)
    a, b = p0 - 300.0 * d, p0 + 300.0 * d
    fit_q = straight_line_joints(a, b, 40, x=x0, seed_joints=start, rng=rng)
    on_line = straight_line_joints(a, b, 300, x=x0, seed_joints=start, rng=rng)
    # Inside every joint's measured span, but off the line: the box the line's joints span, drawn uniformly.
    lo, hi = fit_q.min(axis=0), fit_q.max(axis=0)
    off_line = rng.uniform(lo, hi, (100, 6))
    error, found = _held_inside_flagged_away(fit_q, on_line, off_line, seed=1)
    # Off the line, inside every joint's span: flagged by its distance to the line's poses or by a
    # figure far above the line's, with the direction of the parameters behind it; never silent, since the model
    # misses there by ~100 mm (measured 139 mm RMS: the instrument frame's turn about the line is unseen).
    reasons = [str(why) for why in found.extrapolation[300:]]
    assert all("outside the measured" not in why and "no bound on the error" in why for why in reasons)
    assert any("nearest measured pose" in why for why in reasons)
    big = [why for why in reasons if "× the measured region's worst" in why]
    assert big and all("mostly along" in why and "·" in why for why in big)
    assert np.sqrt(np.mean(error[300:] ** 2)) > 10 * np.sqrt(np.mean(error[:300] ** 2))
