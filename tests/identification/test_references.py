"""Calibration from references the cell owns (issue 27, the models' core): a ballbar's anchors, fixed points and
planes, each identified with the robot's parameters, against a simulated truth whose parameters are known.

The truth's base is the nominal one: these records fix no frame, so the fit holds the base and identifies every
reference in that base's frame; a truth in the same gauge can then be compared parameter by parameter."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from harness.ballbar import PIVOTS, aligned_rms, ballbar_campaign, gauge_truth, predicted_rms, reaching
from models import forward_kinematics, iwr, sample_workspace
from models.description.examples import ur5_like
from models.errors import InvalidInput, JointOutOfRange, NonFiniteValue, TooFewMeasurements, WrongShape
from models.identification.diagnosis import Finding
from models.identification.options import IdentificationOptions
from models.identification.reference_fit import identify_references
from models.identification.reference_result import identify_reference_campaign
from models.identification.registration import rigid_fit
from models.kinematics import ForwardJacobianResult
from models.measurements.references import Anchor, FixedPoint, Plane, ReferenceRecords, TrackerPositions
from models.noise import NoiseModel
from models.simulation import perturbed_robot
from models.transforms import rotvec_to_matrix_np

SIGMA_MM = 0.002
DESC = ur5_like()


# ---------------------------------------------------------------------------------------------- derivatives
@pytest.mark.parametrize(
    "reference",
    [
        Anchor("a", (300.0, -200.0, 100.0)),
        Anchor("b", (300.0, -200.0, 100.0), length_unknown=True),
        FixedPoint("p", (100.0, 200.0, 300.0)),
        Plane("f", (0.2, -0.1, 0.97), 150.0),
    ],
    ids=lambda r: f"{r.traits.kind}{'-offset' if getattr(r, 'length_unknown', False) else ''}",
)
def test_each_reference_derivative_matches_finite_differences(reference: Anchor | FixedPoint | Plane) -> None:
    rng = np.random.default_rng(1)
    n, params = 5, 4
    p = rng.normal(0, 300, (n, 3))
    jac = rng.normal(0, 1, (n, 6, params))
    rotations = rotvec_to_matrix_np(rng.normal(0, 1, (n, 3)))

    def at(positions: np.ndarray) -> ForwardJacobianResult:
        return ForwardJacobianResult(positions, rotations, np.zeros((n, 0)), jac)

    dp = jac[:, :3, :]
    u = np.array([s.nominal for s in reference.unknowns]) + rng.normal(0, 0.01, len(reference.unknowns))
    values = rng.uniform(200, 400, n)
    r, d_theta, d_u = reference.residuals(at(p), u, values)
    h = 1e-6
    for k in range(len(u)):  # by its own unknowns
        step = np.zeros_like(u)
        step[k] = h
        plus, minus = reference.residuals(at(p), u + step, values)[0], reference.residuals(at(p), u - step, values)[0]
        np.testing.assert_allclose(d_u[:, :, k], (plus - minus) / 2 / h, atol=1e-6)
    chain = np.zeros_like(d_theta)  # by θ through p: ∂r/∂θ = ∂r/∂p · ∂p/∂θ
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        fd_p = (
            (reference.residuals(at(p + step), u, values)[0] - reference.residuals(at(p - step), u, values)[0]) / 2 / h
        )
        chain += fd_p[:, :, None] * dp[:, None, axis, :]
    np.testing.assert_allclose(d_theta, chain, atol=1e-6)
    assert r.shape == (n, reference.traits.rows)


# ---------------------------------------------------------------------------------------------- ballbar


def _ballbar(seed: int, per_anchor: int = 36) -> tuple[np.ndarray, tuple[ReferenceRecords, ...]]:
    return ballbar_campaign(DESC, seed, per_pivot=per_anchor, sigma_mm=SIGMA_MM)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_three_ballbar_pivots_calibrate_the_robot_to_its_cramer_rao_bound(seed: int) -> None:
    truth, groups = _ballbar(seed)
    fit = identify_references(DESC, groups, noise=NoiseModel(SIGMA_MM, 1e-5))
    assert fit.solver.success
    # What distances cannot see: the base (a frame), and the rotation about and shift along the first axis that
    # turn and lift every anchor with the arm; said, not guessed.
    assert {f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")} <= set(fit.unidentifiable)
    assert {"link1.theta", "link1.d"} <= set(fit.unidentifiable) and "base" in fit.frame
    # χ² honest: the variance factor is that of noise of the stated σ.
    assert fit.covariance.noise_consistent, (fit.covariance.variance_factor, fit.covariance.chi2_interval)
    # The TCP on fresh poses, after the best rigid alignment, within twice the bound the fit predicts for itself
    # (the benchmark holds it to 1.3x over more seeds), and far below the nominal model's error.
    fresh = sample_workspace(DESC, 300, seed=999)
    true_p = forward_kinematics(DESC, fresh, truth).positions
    after = aligned_rms(forward_kinematics(DESC, fresh, fit.parameters).positions, true_p)
    before = aligned_rms(forward_kinematics(DESC, fresh).positions, true_p)
    bound = predicted_rms(DESC, fit, fresh)
    assert after < 2.0 * bound and after < 0.01 * before, (after, bound, before)
    # The anchors' mutual distances (what no gauge moves) and the unknown length offset, within their errors.
    a = np.array([r.values[:3] for r in fit.references])
    for i, j in ((0, 1), (0, 2), (1, 2)):
        error = np.linalg.norm(a[i] - a[j]) - np.linalg.norm(PIVOTS[i] - PIVOTS[j])
        assert abs(error) < 0.01, (i, j, error)
    offset = fit.references[2]
    assert offset.reference.unknowns[-1].name == "anchor.a3.length"
    assert abs(offset.values[3] - 0.35) < 4.5 * offset.std_errors[3], (offset.values[3], offset.std_errors[3])
    assert all(r.rms_residual_mm < 3 * SIGMA_MM for r in fit.references)


def test_too_few_records_of_an_anchor_name_it() -> None:
    _, groups = _ballbar(1, per_anchor=36)
    short = ReferenceRecords(groups[0].reference, groups[0].joints[:3], groups[0].values[:3])
    with pytest.raises(TooFewMeasurements, match="anchor 'a1' has 3 records"):
        identify_references(DESC, (short, *groups[1:]))


# ---------------------------------------------------------------------------------------------- point and plane
def test_fixed_points_and_a_plane_identify_the_robot_and_the_features() -> None:
    seed = 4
    truth = gauge_truth(DESC, seed)
    rng = np.random.default_rng(seed)
    groups = []
    points = np.array([[400.0, 100.0, 200.0], [-100.0, 420.0, 150.0], [250.0, -350.0, 300.0], [300.0, 300.0, 450.0]])
    for k, point in enumerate(points):
        joints = reaching(DESC, truth, np.tile(point, (14, 1)), seed + k)
        assert joints.shape[0] >= 8
        joints = joints[:10]
        # The TCP sits in the socket to within σ: the records' joints are the truth's (the point is what moves).
        groups.append(ReferenceRecords(FixedPoint(f"p{k + 1}", (0.0, 0.0, 0.0)), joints, np.zeros(len(joints))))
    normal, offset = np.array([0.0, 0.0, 1.0]), 60.0
    on_plane = np.column_stack([rng.uniform(150, 450, 40), rng.uniform(-300, 300, 40), np.full(40, offset)])
    joints = reaching(DESC, truth, on_plane, seed + 10)[:30]
    groups.append(ReferenceRecords(Plane("f1", tuple(normal), offset), joints, np.zeros(len(joints))))
    with pytest.raises(InvalidInput, match="fix no length") as refused:
        identify_references(DESC, tuple(groups))
    assert refused.value.reason == "no_length_scale"
    # One ballbar pivot beside them gives the length (exact distances, as the points' and the plane's records).
    bar = sample_workspace(DESC, 30, seed=seed)
    distance = np.linalg.norm(forward_kinematics(DESC, bar, truth).positions - PIVOTS[0], axis=1)
    groups.append(ReferenceRecords(Anchor("a1", (0.0, 0.0, 0.0)), bar, distance))
    fit = identify_references(DESC, tuple(groups), noise=NoiseModel(SIGMA_MM, 1e-5))
    assert fit.solver.success and "base.x" in fit.unidentifiable
    # Exact records: the fit is the truth up to the rigid motion these records leave free, to the solver's
    # tolerance, and the points are the true points after that motion.
    fresh = sample_workspace(DESC, 100, seed=77)
    fitted, true_p = (forward_kinematics(DESC, fresh, theta).positions for theta in (fit.parameters, truth))
    motion = rigid_fit(fitted, true_p)
    assert aligned_rms(fitted, true_p) < 1e-4
    found = motion.apply(np.array([r.values for r in fit.references[:4]]))
    np.testing.assert_allclose(found, points, atol=1e-4)
    assert max(r.rms_residual_mm for r in fit.references) < 1e-6


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_plane_touched_along_a_line_is_refused() -> None:
    truth = gauge_truth(DESC, 5)
    line = np.column_stack([np.linspace(200, 400, 12), np.full(12, 50.0), np.full(12, 80.0)])
    joints = reaching(DESC, truth, line, 5)
    plane = ReferenceRecords(Plane("f1", (0.0, 0.0, 1.0), 80.0), joints, np.zeros(len(joints)))
    _, groups = _ballbar(1)
    with pytest.raises(InvalidInput, match="plane 'f1': every touch lies on one line") as refused:
        identify_references(DESC, (*groups, plane))
    assert refused.value.reason == "collinear_touches"


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_narrowed_estimate_holds_the_rest() -> None:
    _, groups = _ballbar(2)
    fit = identify_references(DESC, groups, options=IdentificationOptions(estimate=("tool",)))
    names = {fit.table.names[i] for i in fit.estimated}
    assert names and all(n.startswith("tool.") for n in names)


# ---------------------------------------------------------------------------------------------- mixed with a tracker
def test_tracker_positions_beside_the_ballbar_fix_the_frame_and_the_anchors_in_it() -> None:
    """A campaign mixing kinds: a few tracker positions (the tracker 3 m away, turned 30°: its frame is the
    robot's base) fix the frame the ballbar alone leaves free; base, robot and anchors come out in the tracker's
    frame, the TCP within its bound without any alignment."""
    seed = 6
    rng = np.random.default_rng(seed)
    truth = perturbed_robot(DESC, seed=seed).truth  # the base is the tracker's frame, far from nominal
    joints = sample_workspace(DESC, 15, seed=61)
    seen = forward_kinematics(DESC, joints, truth).positions + rng.normal(0, SIGMA_MM, (15, 3))
    groups = [ReferenceRecords(TrackerPositions(), joints, seen)]
    world_anchors = forward_kinematics(DESC, sample_workspace(DESC, 3, seed=62), truth).positions  # in its frame
    for k, anchor in enumerate(world_anchors):
        bar = sample_workspace(DESC, 30, seed=63 + k)
        d = np.linalg.norm(forward_kinematics(DESC, bar, truth).positions - anchor, axis=1)
        d = d + rng.normal(0, SIGMA_MM, 30)
        groups.append(ReferenceRecords(Anchor(f"a{k + 1}", (0.0, 0.0, 0.0)), bar, d))
    fit = identify_references(DESC, tuple(groups), noise=NoiseModel(SIGMA_MM, 1e-5))
    assert fit.solver.success and fit.covariance.noise_consistent
    assert not {n for n in fit.unidentifiable if n.startswith("base.")} - {"base.rz"}  # at most what θ1 absorbs
    assert "tracker" in fit.frame
    for ref, anchor in zip(fit.references[1:], world_anchors, strict=True):
        assert np.abs((ref.values[:3] - anchor) / ref.std_errors[:3]).max() < 4.5, (
            ref.reference.name,
            ref.values,
            anchor,
        )
    fresh = sample_workspace(DESC, 300, seed=999)
    error = forward_kinematics(DESC, fresh, fit.parameters).positions - forward_kinematics(DESC, fresh, truth).positions
    rms = float(np.sqrt(np.mean(np.sum(error**2, axis=1))))
    assert rms < 2.0 * predicted_rms(DESC, fit, fresh), (rms, predicted_rms(DESC, fit, fresh))


@pytest.mark.parametrize(("unit", "factor"), [("inches", 25.4), ("metres", 1000.0)])
def test_a_bar_read_in_another_unit_is_named_not_fitted(unit: str, factor: float) -> None:
    _, groups = _ballbar(1)
    slipped = ReferenceRecords(groups[1].reference, groups[1].joints, groups[1].values / factor)
    with pytest.raises(InvalidInput, match=f"anchor 'a2': the distances look like {unit}") as refused:
        identify_references(DESC, (groups[0], slipped, groups[2]))
    assert refused.value.reason == "distance_unit" and refused.value.value == unit


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_the_iwr_from_ballbar_data_alone_says_what_it_identifies_and_reaches_its_bound() -> None:
    """The hybrid robot (a hexapod on a carriage) from four pivots × 50 records: what distances can identify of
    it is estimated, the rest (the frame, what turns with the first axis, the tool's orientation, the leg
    coordinates the others absorb) is named and held."""
    desc = iwr()
    truth = perturbed_robot(desc, seed=3).truth.copy()
    truth[desc.slices["base"]] = desc.parameters.nominal[desc.slices["base"]]
    rng = np.random.default_rng(3)
    reach = forward_kinematics(desc, sample_workspace(desc, 200, seed=1), truth).positions
    low, high = reach.min(axis=0), reach.max(axis=0)
    fractions = ([0.2, 0.2, 0.1], [0.8, 0.3, 0.2], [0.5, 0.8, 0.1], [0.3, 0.6, 0.9])
    groups = []
    for k, fraction in enumerate(fractions):
        pivot = low + (high - low) * np.array(fraction)
        joints = sample_workspace(desc, 50, seed=10 + k)
        d = np.linalg.norm(forward_kinematics(desc, joints, truth).positions - pivot, axis=1) + rng.normal(
            0, SIGMA_MM, 50
        )
        groups.append(ReferenceRecords(Anchor(f"a{k + 1}", (0.0, 0.0, 0.0)), joints, d))
    fit = identify_references(desc, tuple(groups), noise=NoiseModel(SIGMA_MM, 1e-5))
    assert fit.solver.success and fit.covariance.noise_consistent
    held = set(fit.unidentifiable)
    assert {f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")} | {"tool.rx", "tool.ry", "tool.rz"} <= held
    assert len(fit.estimated) + len(held) == len(desc.parameters) and len(fit.estimated) >= 40
    fresh = sample_workspace(desc, 300, seed=999)
    true_p = forward_kinematics(desc, fresh, truth).positions
    bound = predicted_rms(desc, fit, fresh, stated=True)
    after = aligned_rms(forward_kinematics(desc, fresh, fit.parameters).positions, true_p)
    before = aligned_rms(forward_kinematics(desc, fresh).positions, true_p)
    assert after <= bound and after < 0.02 * before, (after, bound, before)


def test_a_misread_distance_is_named_and_left_out() -> None:
    truth, groups = _ballbar(2)
    values = groups[1].values.copy()
    values[7] += 0.5  # one reading 250 σ off (a bumped bar, a typo)
    slipped = ReferenceRecords(groups[1].reference, groups[1].joints, values, groups[1].sigma_mm)
    fit = identify_references(DESC, (groups[0], slipped, groups[2]), noise=NoiseModel(SIGMA_MM, 1e-5))
    assert [(o.reference, o.record, o.excluded) for o in fit.outliers] == [("a2", 7, True)]
    assert fit.covariance.noise_consistent and fit.references[1].records == groups[1].size - 1
    fresh = sample_workspace(DESC, 300, seed=999)
    after = aligned_rms(
        forward_kinematics(DESC, fresh, fit.parameters).positions, forward_kinematics(DESC, fresh, truth).positions
    )
    assert after < 2.0 * predicted_rms(DESC, fit, fresh)


def test_many_bad_records_are_named_not_dropped() -> None:
    _, groups = _ballbar(3)
    rng = np.random.default_rng(0)
    noisy = tuple(
        ReferenceRecords(g.reference, g.joints, g.values + rng.normal(0, 0.05, g.size), g.sigma_mm) for g in groups
    )  # every record 25 σ off: the stated noise is wrong, not a few records
    fit = identify_references(DESC, noisy, noise=NoiseModel(SIGMA_MM, 1e-5))
    assert len(fit.outliers) > 0.2 * sum(g.size for g in groups) and not any(o.excluded for o in fit.outliers)
    assert [r.records for r in fit.references] == [g.size for g in groups]  # every record kept
    assert not fit.covariance.noise_consistent


def test_bad_records_are_refused_naming_the_reference_and_the_record() -> None:
    _, groups = _ballbar(1)
    first = groups[0]
    nan = first.values.copy()
    nan[4] = np.nan
    out_of_range = first.joints.copy()
    out_of_range[2, 1] = DESC.joint_max[1] + 1.0
    cases = [
        (ReferenceRecords(first.reference, first.joints, nan), NonFiniteValue, "anchor 'a1', record 4"),
        (ReferenceRecords(first.reference, out_of_range, first.values), JointOutOfRange, "q2"),
        (ReferenceRecords(first.reference, first.joints, first.values, -np.ones(first.size)), InvalidInput, "sigma"),
        (ReferenceRecords(first.reference, first.joints[:, :4], first.values), WrongShape, "joint"),
    ]
    for bad, error, message in cases:
        with pytest.raises(error, match=message):
            identify_references(DESC, (bad, *groups[1:]))


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_touches_of_another_face_under_one_plane_name_are_named_as_such() -> None:
    """Some forty touches of one plate, the first eight on a step 0.4 mm higher: those are left out as blunders
    and the result says that they lie on a plane of their own (the step), not that they are random mistakes."""
    seed = 8
    truth = gauge_truth(DESC, seed)
    rng = np.random.default_rng(seed)
    on_plate = np.column_stack([rng.uniform(150, 450, 44), rng.uniform(-300, 300, 44), np.full(44, 60.0)])
    on_plate[:8, 2] += 0.4  # the step
    joints = reaching(DESC, truth, on_plate, seed)
    reached = forward_kinematics(DESC, joints, truth).positions
    step = np.flatnonzero(reached[:, 2] > 60.2)
    assert step.size >= 5 and joints.shape[0] >= 30
    bars = [sample_workspace(DESC, 30, seed=seed + k) for k in range(3)]
    groups = [
        ReferenceRecords(
            Anchor(f"a{k + 1}", (0.0, 0.0, 0.0)),
            bar,
            np.linalg.norm(forward_kinematics(DESC, bar, truth).positions - PIVOTS[k], axis=1)
            + rng.normal(0, SIGMA_MM, 30),
        )
        for k, bar in enumerate(bars)
    ]
    touches = ReferenceRecords(Plane("f1", (0.0, 0.0, 1.0), 60.0), joints, np.zeros(len(joints)))
    offset = sum(g.size for g in groups)
    touches = replace(touches, index=np.arange(offset, offset + touches.size))
    result = identify_reference_campaign(DESC, (*groups, touches), noise=NoiseModel(SIGMA_MM, 1e-5))
    assert result.succeeded
    [found] = [d for d in result.diagnoses if d.finding is Finding.OTHER_PLANE]
    assert set(found.records) == {offset + int(i) for i in step} and not found.blocking
    assert "+0.4 mm" in found.message or "-0.4 mm" in found.message
    assert {o.pose for o in result.outliers if o.excluded} == set(found.records)
