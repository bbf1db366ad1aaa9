"""The quick check (models.evaluation.checks) and its design (optimal_design.checks) on simulated truths.

Independent truths: a version equal to the truth with no parameter uncertainty makes the statistic exactly χ²
(pure instrument noise), so its false-alarm rate is α; a known change of one parameter must come back as that
parameter with its size; a version calibrated from a simulated campaign (a fresh one per seed) must keep the
stated false-alarm rate once its covariance is propagated. Rates are checked with binomial tolerances (a
failure by chance has probability below 1e-3 in each test).
"""

from __future__ import annotations

import time

import numpy as np
import pytest
import scipy.stats

from harness.checks import Calibrated, calibrated, changed, tcp_equivalent
from models import NoiseModel, forward_kinematics, sample_workspace
from models.campaign import Campaign
from models.description.examples import ur5_like
from models.errors import InvalidInput, WrongShape
from models.evaluation.checks import (
    CheckAction,
    CheckOptions,
    Verdict,
    check_references,
    check_version,
    detectable_changes,
    version_covariance,
)
from models.measurements.references import Anchor, ReferenceRecords
from models.simulation import SimulatedRobot, measure, perturbed_robot
from optimal_design.checks import design_check, watched_parameters

DESC = ur5_like()
TABLE = DESC.parameters
AXIS3 = TABLE.index["link3.theta"]
NOISE = NoiseModel()


def _records(robot: SimulatedRobot, joints: np.ndarray, seed: int) -> Campaign:
    """Tracker positions, as the version was calibrated from."""
    return measure(robot, joints, seed=seed, position_only=True)


def _binomial_max(n: int, p: float) -> int:
    """The count that n trials of probability p exceed with probability below 1e-3."""
    return int(scipy.stats.binom.ppf(1 - 1e-3, n, p))


@pytest.fixture(scope="module")
def version() -> Calibrated:
    return calibrated(DESC, 11)


@pytest.fixture(scope="module")
def design(version: Calibrated) -> np.ndarray:
    return design_check(DESC, version.params, 8, covariance=version.covariance, seed=3).joints


def _exact(seed: int) -> tuple[SimulatedRobot, np.ndarray]:
    robot = perturbed_robot(DESC, seed)
    return robot, np.zeros((len(TABLE), len(TABLE)))


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
@pytest.mark.parametrize("position_only", [True, False])
def test_against_the_truth_itself_the_false_alarm_rate_is_alpha(position_only: bool) -> None:
    robot, zero = _exact(5)
    alpha, n = 0.1, 150
    options = CheckOptions(alpha=alpha)
    flagged, statistics = 0, []
    for seed in range(n):
        joints = sample_workspace(DESC, 6, seed=100 + seed)
        result = check_version(
            DESC, robot.truth, zero, measure(robot, joints, seed=seed, position_only=position_only), options=options
        )
        flagged += result.verdict is not Verdict.FINE
        statistics.append(result.chi2 / result.dof)
    rows = 3 if position_only else 6
    assert result.dof == 6 * rows - 6  # the registration's six unknowns
    assert flagged <= _binomial_max(n, alpha)
    assert flagged >= n - _binomial_max(n, 1 - alpha)
    assert abs(np.mean(statistics) - 1.0) < 0.15  # E χ²/dof = 1, sd of the mean ≈ 0.03


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_alpha_is_the_false_alarm_rate_of_a_calibrated_version() -> None:
    """A fresh calibration per seed: the version's own error is one draw of its covariance, as in service."""
    alpha, n = 0.2, 40
    flagged = 0
    for seed in range(n):
        cal = calibrated(DESC, 1000 + 7 * seed)
        joints = sample_workspace(DESC, 8, seed=seed)
        result = check_version(
            DESC, cal.params, cal.covariance, _records(cal.robot, joints, seed), options=CheckOptions(alpha=alpha)
        )
        flagged += result.verdict is not Verdict.FINE
    assert flagged <= _binomial_max(n, alpha)


def test_a_known_joint_offset_change_comes_back_with_its_size() -> None:
    robot, zero = _exact(6)
    delta = tcp_equivalent(DESC, robot.truth, AXIS3, 0.1)
    joints = sample_workspace(DESC, 8, seed=1)
    exact = measure(changed(robot, AXIS3, delta), joints, NoiseModel(1e-6, 1e-9), seed=0, position_only=True)
    result = check_version(DESC, robot.truth, zero, exact, noise=NoiseModel(1e-3, 1e-6))
    assert result.verdict is Verdict.CHANGED
    assert result.explanation is not None and result.explanation.name == "link3.theta"
    np.testing.assert_allclose(result.explanation.change, [delta], rtol=2e-3)  # linearised: second order left
    assert result.recommendation.action is CheckAction.REFIT
    assert result.recommendation.parameters == ("link3.theta",)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_designed_check_detects_a_tenth_of_a_millimetre_on_axis_3(version: Calibrated, design: np.ndarray) -> None:
    delta = tcp_equivalent(DESC, version.params, AXIS3, 0.1)
    moved = changed(version.robot, AXIS3, delta)
    n, found, named = 40, 0, 0
    for seed in range(n):
        result = check_version(DESC, version.params, version.covariance, _records(moved, design, seed))
        found += result.verdict is Verdict.CHANGED
        named += result.explanation is not None and result.explanation.name == "link3.theta"
    assert found >= n - _binomial_max(n, 0.05)
    assert named >= n - _binomial_max(n, 0.1)


def test_a_tool_change_is_explained_by_the_tool(version: Calibrated, design: np.ndarray) -> None:
    moved = changed(version.robot, TABLE.index["tool.y"], 0.3)
    result = check_version(DESC, version.params, version.covariance, _records(moved, design, 2))
    assert result.verdict is Verdict.CHANGED
    assert result.explanation is not None and "tool.y" in [TABLE.names[i] for i in result.explanation.parameters]
    k = result.explanation.parameters.index(TABLE.index["tool.y"])
    assert abs(result.explanation.change[k] - 0.3) < 0.05


def test_a_crash_is_changed_and_asks_for_a_calibration(version: Calibrated, design: np.ndarray) -> None:
    rng = np.random.default_rng(0)
    truth = version.robot.truth + rng.normal(size=len(TABLE)) * TABLE.scales
    crashed = SimulatedRobot(DESC, version.robot.nominal, truth)
    result = check_version(DESC, version.params, version.covariance, _records(crashed, design, 1))
    assert result.verdict is Verdict.CHANGED and result.explanation is None
    assert result.recommendation.action is CheckAction.CALIBRATE


def test_spread_moderate_changes_are_drift(version: Calibrated, design: np.ndarray) -> None:
    rng = np.random.default_rng(4)
    links = list(TABLE.groups["links"])
    verdicts = []
    for seed in range(10):
        truth = version.robot.truth.copy()
        truth[links] += rng.normal(size=len(links)) * TABLE.scales[links] * 0.05
        drifted = SimulatedRobot(DESC, version.robot.nominal, truth)
        result = check_version(DESC, version.params, version.covariance, _records(drifted, design, seed))
        verdicts.append(result.verdict)
        if result.verdict is Verdict.DRIFTED:
            assert result.chi2 / result.dof <= CheckOptions().drift_ratio
            assert result.recommendation.action is CheckAction.CALIBRATE
    assert verdicts.count(Verdict.DRIFTED) >= 6


def test_without_registration_the_base_is_a_candidate(version: Calibrated, design: np.ndarray) -> None:
    """Measured from the calibration's tracker setup: the base (the instrument frame) is the version's own."""
    options = CheckOptions(register=False)
    same = check_version(DESC, version.params, version.covariance, _records(version.robot, design, 3), options=options)
    assert same.dof == 3 * 8 and not same.registered
    moved = changed(version.robot, TABLE.index["base.z"], 0.3)
    result = check_version(DESC, version.params, version.covariance, _records(moved, design, 3), options=options)
    assert result.verdict is Verdict.CHANGED and result.explanation is not None
    assert TABLE.index["base.z"] in result.explanation.parameters


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_the_detectable_change_is_detected_with_95_percent() -> None:
    """The power formula (non-central χ²) against simulation, exact version."""
    robot, zero = _exact(8)
    joints = sample_workspace(DESC, 8, seed=2)
    (size,) = detectable_changes(DESC, robot.truth, zero, joints, (AXIS3,))
    moved = changed(robot, AXIS3, float(size))
    n = 200
    flagged = sum(
        check_version(DESC, robot.truth, zero, measure(moved, joints, seed=s, position_only=True)).verdict
        is not Verdict.FINE
        for s in range(n)
    )
    assert n - _binomial_max(n, 0.05) <= flagged <= _binomial_max(n, 0.95)


def test_the_design_sees_the_watched_changes_better_than_random_poses(version: Calibrated) -> None:
    result = design_check(DESC, version.params, 8, covariance=version.covariance, seed=3)
    assert result.joints.shape == (8, DESC.n_joints)
    assert result.watched == watched_parameters(DESC, register=True)
    offsets = [k for k, i in enumerate(result.watched) if TABLE.names[i].endswith(".theta")]
    finite = [k for k in offsets if np.isfinite(result.detectable[k])]
    worse = 0
    for seed in range(5):
        other = detectable_changes(
            DESC, version.params, version.covariance, sample_workspace(DESC, 8, seed=50 + seed), result.watched
        )
        worse += float(np.mean(other[finite])) > float(np.mean(result.detectable[finite]))
    assert worse >= 4


def test_covariance_from_std_errors_and_correlation() -> None:
    sd = np.full(len(TABLE), np.nan)
    sd[[0, 2]] = [2.0, 3.0]
    cov = version_covariance(TABLE, sd, [TABLE.names[0], TABLE.names[2]], np.array([[1.0, 0.5], [0.5, 1.0]]))
    assert cov[0, 0] == 4.0 and cov[2, 2] == 9.0 and cov[0, 2] == cov[2, 0] == 3.0
    assert np.count_nonzero(cov) == 4


def test_bad_input_is_refused(version: Calibrated) -> None:
    joints = sample_workspace(DESC, 2, seed=0)
    with pytest.raises(InvalidInput, match="at least 3 records"):
        check_version(DESC, version.params, version.covariance, _records(version.robot, joints, 0))
    with pytest.raises(WrongShape):
        check_version(DESC, version.params, np.eye(3), _records(version.robot, sample_workspace(DESC, 5), 0))
    with pytest.raises(InvalidInput, match="alpha"):
        CheckOptions(alpha=0.0)
    with pytest.raises(InvalidInput, match="poses"):
        design_check(DESC, version.params, 2)


@pytest.mark.serial  # a wall time
def test_a_check_is_fast_warm(version: Calibrated, design: np.ndarray) -> None:
    campaign = _records(version.robot, design, 9)
    check_version(DESC, version.params, version.covariance, campaign)
    started = time.perf_counter()
    for _ in range(10):
        check_version(DESC, version.params, version.covariance, campaign)
    assert (time.perf_counter() - started) / 10 < 0.05


def test_fk_predictions_are_what_the_check_compares(version: Calibrated) -> None:
    """Noise-free records of the version itself: nothing to see, every residual zero."""
    joints = sample_workspace(DESC, 6, seed=4)
    fk = forward_kinematics(DESC, joints, version.params)
    result = check_version(DESC, version.params, version.covariance, Campaign(joints, fk.positions))
    assert result.chi2 < 1e-12 and result.verdict is Verdict.FINE
    np.testing.assert_allclose(result.position_mm, 0.0, atol=1e-9)


def _ballbar(robot: SimulatedRobot, seed: int, n: int = 10, sigma: float = 0.002) -> tuple[ReferenceRecords, ...]:
    """`n` distances (σ `sigma`) from the TCP to a pivot 300 mm beside the poses, its place guessed within 5 mm."""
    rng = np.random.default_rng(seed)
    joints = sample_workspace(DESC, n, seed=seed)
    tcp = forward_kinematics(DESC, joints, robot.truth).positions
    pivot = tcp.mean(axis=0) + np.array([300.0, 0.0, 0.0])
    distances = np.linalg.norm(tcp - pivot, axis=1) + rng.normal(0, sigma, n)
    guess = tuple(float(v) for v in pivot + rng.normal(0, 5, 3))
    return (ReferenceRecords(Anchor("a1", guess), joints, distances, np.full(n, sigma)),)  # type: ignore[arg-type]


@pytest.mark.slow  # many simulated checks: over a second
def test_ballbar_checks_keep_alpha_and_see_a_change(version: Calibrated) -> None:
    """Exact version (zero covariance): the false-alarm rate is α with the anchor's 3 unknowns projected out;
    the calibrated version then sees axis 3's 0.1 mm in ten distances."""
    robot, zero = _exact(9)
    alpha, n = 0.1, 100
    options = CheckOptions(alpha=alpha)
    flagged = 0
    for seed in range(n):
        result = check_references(DESC, robot.truth, zero, _ballbar(robot, seed), noise=NOISE, options=options)
        flagged += result.verdict is not Verdict.FINE
    assert result.dof == 10 - 3 and result.position_mm.shape == (10,)
    assert flagged <= _binomial_max(n, alpha) and flagged >= n - _binomial_max(n, 1 - alpha)
    moved = changed(version.robot, AXIS3, tcp_equivalent(DESC, version.params, AXIS3, 0.1))
    found = sum(
        check_references(DESC, version.params, version.covariance, _ballbar(moved, s)).verdict is Verdict.CHANGED
        for s in range(10)
    )
    assert found >= 9
