"""Pose design for ballbar records (issue 27): the design's predicted TCP error is what fits of simulated
records actually reach, and a designed set of 30 predicts less than random sets of 30."""

from __future__ import annotations

import numpy as np
import pytest

from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.identification.reference_fit import identify_references
from models.measurements.references import Anchor, ReferenceRecords
from models.noise import NoiseModel
from models.simulation import perturbed_robot
from optimal_design import TargetUnreachable
from optimal_design.references import design_reference_records, reference_information, reference_records_for_target

DESC = ur5_like()
SIGMA_MM = 0.002
NOISE = NoiseModel(SIGMA_MM, 1e-5)
ANCHORS = np.array([[450.0, 150.0, 50.0], [-150.0, 450.0, 250.0], [200.0, -400.0, 400.0]])
PER_ANCHOR = 150


def _candidates() -> tuple[ReferenceRecords, ...]:
    return tuple(
        ReferenceRecords(
            Anchor(f"a{k + 1}", (float(a[0]), float(a[1]), float(a[2]))),
            sample_workspace(DESC, PER_ANCHOR, seed=500 + k),
            np.zeros(PER_ANCHOR),
        )
        for k, a in enumerate(ANCHORS)
    )


def _fit_error(indices: np.ndarray, candidates: tuple[ReferenceRecords, ...], seed: int) -> float:
    """RMS TCP error on fresh poses (after the best rigid alignment) of a fit of the chosen records, simulated."""
    from models.identification.registration import rigid_fit  # noqa: PLC0415

    rng = np.random.default_rng(seed)
    truth = perturbed_robot(DESC, seed=seed).truth.copy()
    truth[DESC.slices["base"]] = DESC.parameters.nominal[DESC.slices["base"]]
    groups = []
    for k, group in enumerate(candidates):
        mine = indices[(indices >= k * PER_ANCHOR) & (indices < (k + 1) * PER_ANCHOR)] - k * PER_ANCHOR
        joints = group.joints[mine]
        p = forward_kinematics(DESC, joints, truth).positions
        d = np.linalg.norm(p - ANCHORS[k], axis=1) + rng.normal(0, SIGMA_MM, len(mine))
        groups.append(ReferenceRecords(group.reference, joints, d))
    fit = identify_references(DESC, tuple(groups), noise=NOISE)
    fresh = sample_workspace(DESC, 300, seed=999)
    fitted, true_p = (forward_kinematics(DESC, fresh, t).positions for t in (fit.parameters, truth))
    aligned = rigid_fit(fitted, true_p).apply(fitted)
    return float(np.sqrt(np.mean(np.sum((aligned - true_p) ** 2, axis=1))))


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_the_candidates_blocks_are_the_fits_rows() -> None:
    candidates = _candidates()
    info = reference_information(DESC, candidates, noise=NOISE)
    assert info.size == 3 * PER_ANCHOR and info.rows == 1
    # The robot columns come first and the task weighs them only: the anchors' columns are marginalised.
    n_robot = len(info.free)
    assert np.all(info.task[n_robot:, :] == 0) and np.all(info.task[:, n_robot:] == 0)
    assert info.n_params == n_robot + 3 * 3


@pytest.mark.slow  # six simulated fits and a design over 450 candidates: a few seconds
def test_a_designed_set_of_30_ballbar_records_predicts_and_reaches_less_than_random_ones() -> None:
    candidates = _candidates()
    design = design_reference_records(DESC, candidates, 30, "I", noise=NOISE, seed=1)
    designed = design.metrics["predicted_rms_tcp_mm"]
    random = design.random_baseline["predicted_rms_tcp_mm"]
    assert designed <= 0.8 * random, (designed, random)  # the target
    # The prediction is what simulated fits of those records reach (median over seeds, within 40 %), and they
    # reach less than random sets of 30 do.
    chosen = np.array(design.indices)
    rng = np.random.default_rng(3)
    got_design = np.median([_fit_error(chosen, candidates, s) for s in (11, 12, 13)])
    got_random = np.median(
        [_fit_error(np.sort(rng.choice(3 * PER_ANCHOR, 30, replace=False)), candidates, s) for s in (11, 12, 13)]
    )
    assert 0.6 * designed <= got_design <= 1.4 * designed, (got_design, designed)
    assert got_design < got_random, (got_design, got_random)


@pytest.mark.slow  # a curve of designs over 450 candidates and three simulated fits: a few seconds
def test_how_many_ballbar_records_for_a_target_accuracy() -> None:
    candidates = _candidates()
    goal = 0.0015  # 1.5 µm RMS at the TCP: ~115 records (the minimum, 28, predicts 4.4 µm)
    found = reference_records_for_target(DESC, candidates, rms_tcp_mm=goal, noise=NOISE, seed=1)
    assert found.design is not None and found.measurement == "anchor"
    assert found.design.metrics["predicted_rms_tcp_mm"] <= goal
    curve = {p["count"]: p for p in found.curve}
    assert found.count > 28 and found.count - 1 in curve  # the answer is the smallest count:
    assert curve[found.count - 1]["I_rms_tcp_mm"] > goal  # one record fewer misses the target
    chosen = np.array(found.design.indices)
    reached = np.median([_fit_error(chosen, candidates, s) for s in (21, 22, 23)])
    assert reached <= 1.4 * goal, (reached, found.count)
    with pytest.raises(TargetUnreachable):
        reference_records_for_target(DESC, candidates, rms_tcp_mm=1e-6, noise=NOISE)
