"""Bad input: a clear domain error, or a result marked failed with the reason."""

from __future__ import annotations

import numpy as np
import pytest

from models import NoiseModel, RobotDescription, sample_workspace
from models.campaign import Campaign, make_campaign
from models.errors import (
    InvalidInput,
    InvalidQuaternion,
    JointOutOfRange,
    NonFiniteValue,
    TooFewMeasurements,
    UnknownParameter,
)
from models.identification import IdentificationOptions, identify, minimum_poses, trust_region
from models.kinematics import check_joint_ranges
from models.simulation import measure, perturbed_robot


@pytest.fixture(scope="module")
def campaign(desc: RobotDescription) -> Campaign:
    return measure(perturbed_robot(desc, seed=2), sample_workspace(desc, 40, seed=3), seed=4)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_too_few_measurements_says_how_many_more(desc: RobotDescription, campaign: Campaign) -> None:
    rank, needed = minimum_poses(desc, tuple(range(desc.n_params)), False)
    assert (rank, needed) == (54, 10)
    with pytest.raises(TooFewMeasurements, match="measure 4 more") as err:
        identify(desc, campaign.subset(np.arange(6)))
    assert err.value.data["needed"] == 10
    position_only = Campaign(campaign.joints, campaign.positions)
    assert minimum_poses(desc, tuple(range(desc.n_params)), True) == (51, 18)
    with pytest.raises(TooFewMeasurements):
        identify(desc, position_only.subset(np.arange(17)))


def test_unknown_group_and_bad_options(desc: RobotDescription, campaign: Campaign) -> None:
    with pytest.raises(UnknownParameter, match="wheels"):
        identify(desc, campaign, options=IdentificationOptions(estimate=("base", "wheels")))
    with pytest.raises(InvalidInput, match="robust_scale"):
        IdentificationOptions(robust_scale=0.0)
    with pytest.raises(InvalidInput, match="lower"):
        identify(desc, campaign, options=IdentificationOptions(bounds={"link1.a": (92.0, 90.0)}))
    with pytest.raises(InvalidInput, match="noise"):
        identify(desc, campaign, noise=NoiseModel(0.0, 1e-4))


def test_record_level_errors_name_the_record(desc: RobotDescription, campaign: Campaign) -> None:
    joints = campaign.joints.copy()
    joints[5, 2] = np.radians(200.0)
    with pytest.raises(JointOutOfRange, match="pose 5"):
        make_campaign(desc, joints, campaign.positions, campaign.quaternions)
    positions = campaign.positions.copy()
    positions[3, 1] = np.nan
    with pytest.raises(NonFiniteValue, match="record 3"):
        make_campaign(desc, campaign.joints, positions, campaign.quaternions)
    assert campaign.quaternions is not None
    quats = campaign.quaternions.copy()
    quats[2] *= 1.2
    with pytest.raises(InvalidQuaternion, match="record 2"):
        make_campaign(desc, campaign.joints, campaign.positions, quats)
    quats[2] = campaign.quaternions[2] * (1 + 5e-4)  # near-unit: normalised, accepted
    normalised = make_campaign(desc, campaign.joints, campaign.positions, quats).quaternions
    assert normalised is not None
    assert np.allclose(np.linalg.norm(normalised, axis=1), 1)


def test_a_reading_just_past_its_limit_is_measured_a_command_is_not(desc: RobotDescription, campaign: Campaign) -> None:
    """A joint reading at the stop may pass the description's limit (TIAGo's torso read 350.18 mm against its URDF's
    350 in a real campaign, refused whole): readings within 1 % of the span are records, further is a slip, and a
    command (compensation, a design) still may not pass at all."""
    span = desc.joint_max[0] - desc.joint_min[0]
    joints = campaign.joints.copy()
    joints[7, 0] = desc.joint_max[0] + 0.005 * span
    accepted = make_campaign(desc, joints, campaign.positions, campaign.quaternions)
    assert accepted.joints[7, 0] == joints[7, 0]
    with pytest.raises(JointOutOfRange, match="pose 7"):
        check_joint_ranges(desc, joints)
    joints[7, 0] = desc.joint_min[0] - 0.02 * span
    with pytest.raises(JointOutOfRange, match="pose 7"):
        make_campaign(desc, joints, campaign.positions, campaign.quaternions)


def test_data_from_another_robot_fail_with_a_reason(desc: RobotDescription, campaign: Campaign) -> None:
    # The joint readings belong to other poses than the measurements: no geometry explains them.
    shuffled = Campaign(campaign.joints[::-1].copy(), campaign.positions, campaign.quaternions)
    result = identify(desc, shuffled)
    assert result.status == "failed"
    assert result.reason is not None and "cannot come from this robot" in result.reason


def test_bounds_hold(desc: RobotDescription, campaign: Campaign) -> None:
    i = desc.parameters.index["link3.a"]
    free = identify(desc, campaign)
    assert abs(free.parameters[i] - 252.0) > 0.05
    lo, hi = 252.0 - 0.01, 252.0 + 0.01
    bounded = identify(desc, campaign, options=IdentificationOptions(bounds={"link3.a": (lo, hi)}))
    assert lo - 1e-7 <= bounded.parameters[i] <= hi + 1e-7


def test_solver_failure_gives_a_failed_result(
    desc: RobotDescription, campaign: Campaign, monkeypatch: pytest.MonkeyPatch
) -> None:
    # IPOPT stopped at its limit is finished by the trust region, to the same optimum as without the limit.
    limited = identify(desc, campaign, options=IdentificationOptions(max_iterations=1))
    full = identify(desc, campaign)
    assert limited.succeeded and limited.solver.name == "ipopt+trust-region"
    assert "Maximum_Iterations_Exceeded" in limited.solver.status
    assert limited.residuals_after.rms_mm == pytest.approx(full.residuals_after.rms_mm, rel=1e-6)
    # Where the finish cannot close it either, the result fails and says so.
    monkeypatch.setattr(trust_region, "MAX_EVALUATIONS", 1)
    monkeypatch.setattr(trust_region, "CONVERGED_DECREMENT", 0.0)
    result = identify(desc, campaign, options=IdentificationOptions(max_iterations=1))
    assert result.status == "failed"
    assert result.reason is not None and "IPOPT did not converge" in result.reason
