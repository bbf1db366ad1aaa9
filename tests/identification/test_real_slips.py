"""Slips of real campaigns (issue 45) on simulated robots whose truth is known: found, and fixed or named."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.identification import identify
from models.identification.diagnosis import Finding, diagnose
from models.simulation import SimulatedRobot, measure, perturbed_robot
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

DESC = ur5_like()


def _turned_tool(seed: int, axis: tuple[float, float, float], degrees: float) -> SimulatedRobot:
    """The true robot's tool frame turned by `degrees` about `axis` (tool side) from what the description says."""
    sim = perturbed_robot(DESC, seed=seed)
    truth = sim.truth.copy()
    rot = DESC.slices["tool"].start + 3
    turn = rotvec_to_matrix_np(np.radians(degrees) * np.asarray(axis, dtype=float))
    truth[rot : rot + 3] = matrix_to_rotvec_np(rotvec_to_matrix_np(truth[rot : rot + 3]) @ turn)
    return SimulatedRobot(sim.desc, sim.nominal, truth)


@pytest.mark.parametrize(("axis", "degrees"), [((1.0, 0.0, 0.0), 180.0), ((0.0, 0.0, 1.0), 90.0)])
def test_a_tool_frame_turned_in_the_description_is_estimated_not_blamed_on_the_tracker(
    axis: tuple[float, float, float], degrees: float
) -> None:
    sim = _turned_tool(3, axis, degrees)
    campaign = measure(sim, sample_workspace(DESC, 40, seed=4), seed=5)
    found = diagnose(DESC, campaign.joints, campaign.positions, campaign.quaternions, DESC.parameters.nominal)
    assert [d.finding for d in found] == [Finding.TOOL_ORIENTATION]
    assert not found[0].blocking and f"{degrees:.3g}°" in found[0].message
    result = identify(DESC, campaign)
    assert result.succeeded, result.reason
    fresh = sample_workspace(DESC, 100, seed=6)
    truth = forward_kinematics(DESC, fresh, sim.truth)
    fitted = forward_kinematics(DESC, fresh, result.parameters)
    position = np.sqrt(np.mean(np.sum((fitted.positions - truth.positions) ** 2, axis=1)))
    cos = (np.einsum("nij,nij->n", fitted.rotations, truth.rotations) - 1.0) / 2.0
    angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).max()
    assert position < 0.05  # mm; the noise is 0.025 mm, the nominal model is ~1 mm off
    assert angle < 0.05  # degrees: the tool's 180° (90°) is found to the noise


def test_the_tool_orientation_is_not_mistaken_for_a_flipped_instrument_axis() -> None:
    # Half the records turned 180° about x is no constant tool rotation: still the instrument's output.
    sim = perturbed_robot(DESC, seed=7)
    campaign = measure(sim, sample_workspace(DESC, 40, seed=8), seed=9)
    assert campaign.quaternions is not None
    quats = campaign.quaternions.copy()
    for k in range(0, 40, 2):
        w, x, y, z = quats[k]
        quats[k] = [-x, w, z, -y]
    found = diagnose(DESC, campaign.joints, campaign.positions, quats, DESC.parameters.nominal)
    assert [d.finding for d in found] == [Finding.ORIENTATION_FLIP]
    assert math.isclose(len(found[0].records), 20)


@pytest.mark.parametrize(("joint", "change", "words"), [(1, "negate", "negated"), (2, 90.0, "shifted by -90°")])
def test_a_joint_sign_or_zero_convention_is_named(joint: int, change: str | float, words: str) -> None:
    sim = perturbed_robot(DESC, seed=11)
    campaign = measure(sim, sample_workspace(DESC, 40, seed=12), seed=13, position_only=True)
    sent = campaign.joints.copy()
    # The controller's convention: this joint counts the other way, or from another zero (the description
    # then needs the reading shifted back by -90° to match).
    sent[:, joint] = -sent[:, joint] if change == "negate" else sent[:, joint] + np.radians(float(change))
    found = diagnose(DESC, sent, campaign.positions, None, DESC.parameters.nominal)
    assert [d.finding for d in found] == [Finding.JOINT_CONVENTION]
    assert found[0].blocking and f"joint {DESC.joint_names[joint]} {words}" in found[0].message


def test_a_missing_tool_offset_is_fitted() -> None:
    # The reflector sits 95 mm out on a nest the description does not have: the tool's offset is estimated.
    sim = perturbed_robot(DESC, seed=14)
    truth = sim.truth.copy()
    tool = DESC.slices["tool"].start
    truth[tool : tool + 3] += [0.0, 0.0, 95.0]
    sim = SimulatedRobot(DESC, sim.nominal, truth)
    campaign = measure(sim, sample_workspace(DESC, 40, seed=15), seed=16, position_only=True)
    result = identify(DESC, campaign)
    assert result.succeeded and result.diagnoses == ()
    fresh = sample_workspace(DESC, 100, seed=17)
    error = (
        forward_kinematics(DESC, fresh, result.parameters).positions - forward_kinematics(DESC, fresh, truth).positions
    )
    assert np.sqrt(np.mean(np.sum(error**2, axis=1))) < 0.05
