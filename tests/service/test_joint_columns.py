"""Campaign joint columns as users have them (issue 29): A1 … (KUKA), J1 … (ABB, Fanuc), axis1 …, joint1 …, and
each column's unit as its header states it (`A2 [rad]`), converted rather than read as degrees."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import RobotDescription, iwr, sample_workspace
from models.description.examples import track_arm, ur5_like
from models.description.structure import description_from_document
from models.formats.urdf import document_from_urdf
from models.simulation import measure, perturbed_robot
from service.campaign_io import CampaignFileError, ImportOptions
from service.campaign_io.columns import RobotColumns, parse_column_map
from service.files.csv_codec import joined_campaign, parse_campaign
from tests.irb2400 import IRB2400_URDF, IRB2400_XACRO

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


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
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


# ---------------------------------------------------------------------------- real robot descriptions (issue 45)
UR_NAMES = [
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
]


@pytest.mark.parametrize("style", ["joint_", "panda_joint", "a_", "Joint_", "robot1_joint_"])
def test_urdf_style_joint_names_read_as_the_joints(truth: tuple[np.ndarray, np.ndarray], style: str) -> None:
    joints, poses = truth
    header = [f"{style}{k + 1}" for k in range(6)] + ["x", "y", "z", "qw", "qx", "qy", "qz"]
    got, _ = parse_campaign(_csv(header, np.hstack([joints, poses])))
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-12)


def _ur_robot() -> RobotColumns:
    names = tuple(f"q{k + 1}" for k in range(6))
    return RobotColumns(names, dict(zip(UR_NAMES, names, strict=True)), frozenset(names))


@pytest.mark.parametrize("unit", [" (rad)", " [rad]", "_rad"])
def test_a_robot_s_urdf_names_with_radians_in_the_header(truth: tuple[np.ndarray, np.ndarray], unit: str) -> None:
    joints, poses = truth
    header = [f"{n}{unit}" for n in reversed(UR_NAMES)] + ["x", "y", "z", "qw", "qx", "qy", "qz"]
    got, notes = parse_campaign(_csv(header, np.hstack([np.radians(joints[:, ::-1]), poses])), robot=_ur_robot())
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-9)
    assert any("shoulder_pan_joint → q1" in n for n in notes) and sum("converted to degrees" in n for n in notes) == 6
    with pytest.raises(CampaignFileError, match="URDF names are read too: elbow_joint"):
        parse_campaign(_csv(["pan", "x", "y", "z"], np.zeros((1, 4))), robot=_ur_robot())


def test_a_column_map_and_a_joint_unit_option(truth: tuple[np.ndarray, np.ndarray]) -> None:
    joints, poses = truth
    # A German controller export: 'Achse 1' … and the tracker's X_m, Y_m, Z_m; the map says which is which,
    # the joints are radians by option (the header states no unit).
    header = [f"Achse {k + 1}" for k in range(6)] + ["Xm", "Ym", "Zm", "qw", "qx", "qy", "qz"]
    text = _csv(header, np.hstack([np.radians(joints), poses[:, :3] / 1000, poses[:, 3:]]))
    mapping = ",".join([f"Achse {k + 1}={UR_NAMES[k]}" for k in range(6)] + ["Xm=x", "Ym=y", "Zm=z"])
    options = ImportOptions(columns=parse_column_map(mapping), joint_unit="rad", length_unit="m")
    got, _ = parse_campaign(text, options=options, robot=_ur_robot())
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(np.array([g["position"] for g in got], dtype=float), poses[:, :3], rtol=1e-12, atol=1e-9)


def test_joint_unit_converts_only_the_revolute_joints() -> None:
    desc = track_arm()
    joints, poses = _measured(desc, 6, 4)
    names = desc.joint_names
    turning = frozenset(n for n, k in zip(names, desc.joint_kinds, strict=True) if k.value == "angle")
    robot = RobotColumns(names, {}, turning)
    sent = joints.copy()
    revolute = [k for k, n in enumerate(names) if n in turning]
    sent[:, revolute] = np.radians(sent[:, revolute])
    got, _ = parse_campaign(
        _csv([*names, "x", "y", "z", "qw", "qx", "qy", "qz"], np.hstack([sent, poses])),
        options=ImportOptions(joint_unit="rad"),
        robot=robot,
    )
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-9)  # the track's mm untouched


@pytest.mark.parametrize(
    ("mapping", "message"),
    [
        ("J1", "write FILE_COLUMN=JOINT_OR_COORDINATE"),
        ("J1=q1,J1=q2", r"names the file column\(s\) j1 twice"),
        ("A1=elbow", "neither a joint of this robot"),
        ("Nope=q1", "the header lacks"),
        ("A1=q1,A2=q1", "q1 would be two columns"),
    ],
)
def test_column_map_mistakes_are_named(mapping: str, message: str) -> None:
    header = [f"A{k + 1}" for k in range(6)] + ["x", "y", "z"]
    with pytest.raises(CampaignFileError, match=message):
        parse_campaign(
            _csv(header, np.zeros((2, 9))), options=ImportOptions(columns=parse_column_map(mapping)), robot=_ur_robot()
        )


def _irb(client: TestClient) -> tuple[str, RobotDescription]:
    made = client.post(
        "/v1/robots", json={"name": "irb2400", "urdf": IRB2400_URDF, "base_link": "base_link", "tip_link": "tool0"}
    )
    assert made.status_code == 201, made.text
    return made.json()["id"], description_from_document(document_from_urdf(IRB2400_URDF, "base_link", "tool0"))


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_an_irb2400_campaign_under_its_urdf_joint_names_calibrates_and_radians_are_named(client: TestClient) -> None:
    """Issue 45: ROS-Industrial's IRB 2400 names its joints joint_1 …: such a campaign was refused until renamed;
    and joints sent in radians to its ±200° and ±400° wrist were called a mismatch, not radians."""
    robot, desc = _irb(client)
    assert client.get(f"/v1/robots/{robot}").json()["joint_names"] == [f"q{k + 1}" for k in range(6)]
    joints, poses = _measured(desc, 40, 9)
    header = [f"joint_{k + 1}" for k in range(6)] + ["x", "y", "z", "qw", "qx", "qy", "qz"]
    url = f"/v1/robots/{robot}/calibrations"
    r = client.post(url, content=_csv(header, np.hstack([joints, poses])), headers={"content-type": "text/csv"})
    assert r.status_code == 201, r.text
    assert r.json()["status"] == "succeeded" and r.json()["residuals"]["after"]["rms_mm"] < 0.1
    in_radians = np.radians(joints)
    assert np.abs(in_radians).max() > math.pi  # beyond what the old ±π check looked for
    r = client.post(url, content=_csv(header, np.hstack([in_radians, poses])), headers={"content-type": "text/csv"})
    problem = r.json()
    assert r.status_code == 422 and [d["finding"] for d in problem["diagnoses"]] == ["radians"], problem
    assert "joint_unit=rad" in problem["detail"]
    # The same file with the option is read as radians and calibrates.
    r = client.post(
        url + "?joint_unit=rad",
        content=_csv(header, np.hstack([in_radians, poses])),
        headers={"content-type": "text/csv"},
    )
    assert r.status_code == 201 and r.json()["status"] == "succeeded", r.text


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_column_map_through_the_api_and_its_mistake_a_400(client: TestClient, robot_id: str) -> None:
    desc = iwr()
    joints, poses = _measured(desc, 40, 12)
    header = [f"Achse {k + 1}" for k in range(4)] + [f"Bein {k}" for k in range(1, 7)] + ["x", "y", "z"]
    mapping = ",".join([f"Achse {k + 1}=q{k + 1}" for k in range(4)] + [f"Bein {k}=l{k}" for k in range(1, 7)])
    url = f"/v1/robots/{robot_id}/calibrations"
    text = _csv(header, np.hstack([joints, poses[:, :3]]))
    r = client.post(url, params={"columns": mapping}, content=text, headers={"content-type": "text/csv"})
    assert r.status_code == 201, r.text
    assert any("achse_1 → q1" in n for n in r.json()["notes"])
    r = client.post(url, params={"columns": "Achse 9=q1"}, content=text, headers={"content-type": "text/csv"})
    assert r.status_code == 400 and "achse_9" in r.json()["detail"]


def test_a_xacro_upload_is_named_with_the_command_that_expands_it(client: TestClient) -> None:
    for body in (
        {"name": "x1", "urdf": IRB2400_XACRO, "base_link": "", "tip_link": ""},  # what the browser sent
        {"name": "x2", "urdf": IRB2400_XACRO},
    ):
        r = client.post("/v1/robots", json=body)
        assert r.status_code == 422, r.text
        detail = r.json()["detail"]
        assert "xacro file" in detail and "xacro robot.urdf.xacro > robot.urdf" in detail and "ros2 run xacro" in detail


def test_a_controller_file_under_urdf_names_joined_with_a_leica_point_file(
    truth: tuple[np.ndarray, np.ndarray],
) -> None:
    joints, poses = truth
    ids = [f"P{k + 1}" for k in range(len(joints))]
    joint_file = "\n".join(
        ["Point ID," + ",".join(f"{n} (rad)" for n in UR_NAMES)]
        + [f"{pid}," + ",".join(repr(float(v)) for v in np.radians(row)) for pid, row in zip(ids, joints, strict=True)]
    )
    point_file = "\n".join(
        ["Point ID;Target;X [mm];Y [mm];Z [mm];U(95) [mm]"]
        + [
            f"{pid};TMC 30-B #5320;" + ";".join(repr(float(v)).replace(".", ",") for v in p[:3]) + ";0,02"
            for pid, p in reversed(list(zip(ids, poses, strict=True)))
        ]
    )
    got, notes = joined_campaign(joint_file, point_file, spatial_analyzer=False, robot=_ur_robot())
    np.testing.assert_allclose(_joints(got), joints, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(np.array([g["position"] for g in got], dtype=float), poses[:, :3], atol=1e-12)
    assert all(g["sigma_mm"] == pytest.approx(0.01) for g in got)
    assert any("wrist_3_joint → q6" in n for n in notes) and any("reflector" in n for n in notes)
    # A map entry naming a column neither file has is named with what the files have.
    with pytest.raises(CampaignFileError, match="which no file has"):
        joined_campaign(
            joint_file,
            point_file,
            spatial_analyzer=False,
            robot=_ur_robot(),
            options=ImportOptions(columns=parse_column_map("Axis 7=q1")),
        )
