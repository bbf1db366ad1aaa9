"""Campaign joint columns as users have them (issue 29): A1 … (KUKA), J1 … (ABB, Fanuc), axis1 …, joint1 …, and
each column's unit as its header states it (`A2 [rad]`), converted rather than read as degrees."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import RobotDescription, iwr, sample_workspace
from models.examples import ur5_like
from models.simulation import measure, perturbed_robot
from service.campaign_io import CampaignFileError
from service.csv_codec import parse_campaign

UR5 = ur5_like()


def _measured(desc: RobotDescription, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(joints in the API's units (deg, mm), x y z qw qx qy qz) of `n` simulated tracker records."""
    campaign = measure(perturbed_robot(desc, seed=seed), sample_workspace(desc, n, seed=seed + 1), seed=seed + 2)
    assert campaign.quaternions is not None
    return campaign.joints * desc.joint_to_boundary, np.hstack([campaign.positions, campaign.quaternions])


@pytest.fixture(scope="module")
def truth() -> tuple[np.ndarray, np.ndarray]:
    return _measured(UR5, 8, 21)


def _csv(header: list[str], rows: np.ndarray) -> str:
    return "\n".join([",".join(header), *(",".join(repr(float(v)) for v in row) for row in rows)]) + "\n"


def _joints(got: list[dict[str, object]]) -> np.ndarray:
    return np.array([g["joints"] for g in got], dtype=float)


@pytest.mark.parametrize("style", ["q", "A", "J", "axis", "Joint"])
@pytest.mark.parametrize("unit", ["", " [deg]", " [rad]"])
def test_each_numbering_and_angle_unit_reads_the_same_joints(
    truth: tuple[np.ndarray, np.ndarray], style: str, unit: str
) -> None:
    joints, poses = truth
    factor = math.pi / 180 if unit == " [rad]" else 1.0
    header = [f"{style}{k + 1}{unit}" for k in range(6)] + ["x", "y", "z", "qw", "qx", "qy", "qz"]
    got, notes = parse_campaign(_csv(header, np.hstack([joints * factor, poses])))
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-12)
    converted = [n for n in notes if "converted to degrees" in n]
    assert len(converted) == (6 if unit == " [rad]" else 0), notes


def test_a_prismatic_joint_in_metres_is_converted_to_mm() -> None:
    joints, poses = _measured(iwr(), 4, 3)
    header = ["q1 [m]", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
    in_metres = joints.copy()
    in_metres[:, 0] /= 1000
    got, notes = parse_campaign(_csv(header, np.hstack([in_metres, poses])))
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12)
    assert any("q1 is in m: converted to mm" in n for n in notes)


@pytest.mark.parametrize(
    ("header", "message"),
    [
        (["q1", "A2", "q3", "x", "y", "z"], "numbers its joints in more than one way"),
        (["A1 [grad]", "A2", "x", "y", "z"], "unknown joint unit 'grad'"),
        (["A1", "A3", "x", "y", "z"], "the joint columns skip a2"),
        (["x", "y", "z", "speed"], "names no joint column"),
    ],
)
def test_joint_column_mistakes_are_named(header: list[str], message: str) -> None:
    rows = np.arange(len(header), dtype=float)[None, :]
    with pytest.raises(CampaignFileError, match=message):
        parse_campaign(_csv(header, rows))


def test_the_no_joint_message_speaks_of_a_serial_arm_first() -> None:
    with pytest.raises(CampaignFileError) as raised:
        parse_campaign(_csv(["x", "y", "z"], np.array([[1.0, 2.0, 3.0]])))
    detail = str(raised.value)
    assert detail.index("q1 … q_m") < detail.index("l1 … l6")  # a Panda user is told of joints before legs


def test_a_kuka_style_campaign_in_radians_calibrates_through_the_api(client: TestClient, robot_id: str) -> None:
    desc = iwr()
    joints, poses = _measured(desc, 40, 2)
    revolute = [k for k, link in enumerate(desc.links) if link.joint.value == "revolute"]
    header = [f"A{k + 1}" + (" [rad]" if k in revolute else "") for k in range(4)]
    header += [f"l{k}" for k in range(1, 7)] + ["x", "y", "z", "qw", "qx", "qy", "qz"]
    in_file = joints.copy()
    in_file[:, revolute] *= math.pi / 180
    answer = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        content=_csv(header, np.hstack([in_file, poses])),
        headers={"content-type": "text/csv"},
    )
    assert answer.status_code == 201, answer.text
    body = answer.json()
    assert body["status"] == "succeeded" and body["residuals"]["after"]["rms_mm"] < 0.1
    assert any("converted to degrees" in n for n in body["notes"])
