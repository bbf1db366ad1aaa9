"""Each slip made on purpose on a simulated campaign, and the diagnosis must name it (and nothing on clean data)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from models import iwr, sample_workspace
from models.campaign import Campaign
from models.identification import identify
from models.identification.diagnosis import Finding, diagnose
from models.simulation import measure, perturbed_robot

DESC = iwr()
NOMINAL = DESC.parameters.nominal


def _campaign(seed: int, n: int = 40) -> Campaign:
    sim = perturbed_robot(DESC, seed=seed)
    return measure(sim, sample_workspace(DESC, n, seed=seed + 100), seed=seed + 200)


def _findings(joints: np.ndarray, positions: np.ndarray, quats: np.ndarray | None) -> list[Finding]:
    return [d.finding for d in diagnose(DESC, joints, positions, quats, NOMINAL)]


@pytest.mark.parametrize("seed", range(6))
def test_a_clean_campaign_raises_no_alarm(seed: int) -> None:
    c = _campaign(seed)
    assert diagnose(DESC, c.joints, c.positions, c.quaternions, NOMINAL) == ()


def test_revolute_joints_sent_in_radians() -> None:
    c = _campaign(1)
    joints = c.joints.copy()
    revolute = [2, 3]
    joints[:, revolute] = np.radians(joints[:, revolute])  # the client sent rad where the API expects deg
    found = diagnose(DESC, joints, c.positions, c.quaternions, NOMINAL)
    assert [d.finding for d in found] == [Finding.RADIANS]
    assert "q3, q4" in found[0].message and "degrees" in found[0].message


@pytest.mark.parametrize(("factor", "unit"), [(1e-3, "metres"), (1 / 25.4, "inches")])
def test_positions_in_metres_or_inches(factor: float, unit: str) -> None:
    c = _campaign(2)
    found = diagnose(DESC, c.joints, c.positions * factor, c.quaternions, NOMINAL)
    assert [d.finding for d in found] == [Finding.LENGTH_SCALE] and unit in found[0].message


def test_a_left_handed_instrument_frame() -> None:
    c = _campaign(3)
    mirrored = c.positions * np.array([1.0, -1.0, 1.0])
    found = diagnose(DESC, c.joints, mirrored, c.quaternions, NOMINAL)
    assert [d.finding for d in found] == [Finding.REFLECTION] and "left-handed" in found[0].message


def test_quaternions_in_xyzw_order() -> None:
    c = _campaign(4)
    assert c.quaternions is not None
    xyzw = np.roll(c.quaternions, -1, axis=1)
    found = diagnose(DESC, c.joints, c.positions, xyzw, NOMINAL)
    assert [d.finding for d in found] == [Finding.QUATERNION_ORDER] and "[w, x, y, z]" in found[0].message


def test_orientations_flipped_by_180_degrees_on_some_records() -> None:
    c = _campaign(5)
    assert c.quaternions is not None
    quats = c.quaternions.copy()
    # A 180° turn about x: q ⊗ (0, 1, 0, 0) = (−x, w, −z, y) for q = (w, x, y, z).
    for k in (3, 17):
        w, x, y, z = quats[k]
        quats[k] = [-x, w, z, -y]
    found = diagnose(DESC, c.joints, c.positions, quats, NOMINAL)
    assert [d.finding for d in found] == [Finding.ORIENTATION_FLIP] and found[0].records == (3, 17)


def test_single_records_far_off_are_named_worst_first() -> None:
    c = _campaign(6)
    positions = c.positions.copy()
    positions[9] += [60.0, 0, 0]  # a wrong row: another pose's point
    positions[22] += [0, 0, -150.0]
    found = diagnose(DESC, c.joints, positions, c.quaternions, NOMINAL)
    assert [d.finding for d in found] == [Finding.FAR_RECORDS]
    assert found[0].records == (22, 9) and not found[0].blocking
    assert "22 (1" in found[0].message and "9 (" in found[0].message


def test_the_joint_check_needs_wide_revolute_ranges() -> None:
    """The radians test only speaks where degrees and radians differ: a campaign at small angles is not flagged."""
    c = _campaign(7)
    small = c.joints.copy()
    small[:, 2:4] = np.clip(small[:, 2:4], 0, math.radians(3.0))  # real readings, all below 3°
    findings = _findings(small, c.positions, c.quaternions)
    assert Finding.RADIANS in findings  # indistinguishable from radians: flagged, with the message saying why
    wide = c.joints.copy()
    wide[0, 2] = math.radians(120.0)  # one real reading beyond π degrees is enough to rule radians out
    assert Finding.RADIANS not in _findings(wide, c.positions, c.quaternions)


def test_identify_names_the_slip_instead_of_failing_blindly() -> None:

    c = _campaign(8)
    metres = Campaign(c.joints, c.positions / 1000.0, c.quaternions)
    result = identify(DESC, metres)
    assert not result.succeeded and result.solver.status == "not_run"
    assert result.reason is not None and "metres" in result.reason
    assert [d.finding for d in result.diagnoses] == [Finding.LENGTH_SCALE]


def test_far_records_are_noted_and_the_fit_goes_on() -> None:

    c = _campaign(9, n=50)
    positions = c.positions.copy()
    positions[13] += [0.0, 80.0, 0.0]
    result = identify(DESC, Campaign(c.joints, positions, c.quaternions))
    assert result.succeeded, result.reason
    assert any("13 (" in n for n in result.notes)
    assert [o.pose for o in result.outliers if o.excluded] == [13]


def test_joint_rows_of_other_poses_are_a_mismatch() -> None:
    c = _campaign(10)
    found = diagnose(DESC, c.joints[::-1].copy(), c.positions, c.quaternions, NOMINAL)
    assert [d.finding for d in found] == [Finding.MISMATCH] and "same order" in found[0].message
