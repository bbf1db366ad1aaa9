"""Robots of any structure over the API: created from a document or a URDF, described back, used with joint
vectors of their own length, exported as URDF and as a document that POST /v1/robots accepts again."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, sample_workspace
from models.description.examples import hexapod_alone, hexapod_alone_document, iiwa_like, iiwa_like_document
from models.simulation import measure, perturbed_robot
from tests.models.test_urdf import UR5_URDF


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_7r_arm_from_its_document(client: TestClient) -> None:
    made = client.post("/v1/robots", json={"name": "arm", "structure": iiwa_like_document()})
    assert made.status_code == 201, made.text
    robot = made.json()
    assert robot["model"] == "custom"
    assert robot["joint_names"] == [f"q{i}" for i in range(1, 8)]
    assert robot["joint_units"] == ["deg"] * 7
    assert robot["parameter_count"] == 6 + 7 * 4 + 1 + 6
    assert robot["structure"]["stages"][0]["convention"] == "mdh"
    q_deg = [10.0, 20.0, -30.0, 40.0, 15.0, -25.0, 5.0]
    url = f"/v1/robots/{robot['id']}/forward-kinematics"
    pose = client.post(url, json={"joints": [q_deg]}).json()["poses"][0]
    expected = forward_kinematics(iiwa_like(), np.radians(q_deg)).positions[0]
    np.testing.assert_allclose(pose["position"], expected, atol=1e-9)
    wrong = client.post(url, json={"joints": [q_deg[:6]]})
    assert wrong.status_code == 422
    assert "7 numbers" in wrong.json()["detail"]
    # the URDF export and the document with the version's values
    urdf = client.get(f"/v1/robots/{robot['id']}/parameters", params={"format": "urdf"})
    assert urdf.status_code == 200 and urdf.text.startswith("<?xml")
    document = client.get(f"/v1/robots/{robot['id']}/structure", params={"version": 1}).json()
    again = client.post("/v1/robots", json={"name": "arm-2", "structure": document})
    assert again.status_code == 201
    pose2 = client.post(f"/v1/robots/{again.json()['id']}/forward-kinematics", json={"joints": [q_deg]}).json()
    np.testing.assert_allclose(pose2["poses"][0]["position"], expected, atol=1e-9)


def test_a_urdf_robot_and_bad_documents(client: TestClient) -> None:
    made = client.post("/v1/robots", json={"name": "ur5", "urdf": UR5_URDF, "base_link": "world", "tip_link": "tool0"})
    assert made.status_code == 201, made.text
    assert len(made.json()["joint_names"]) == 6
    missing = client.post("/v1/robots", json={"name": "ur5", "urdf": UR5_URDF, "base_link": "world"})
    assert missing.status_code == 422
    bad = hexapod_alone_document()
    bad["stages"][0]["strokes"] = [400, 300]
    refused = client.post("/v1/robots", json={"name": "hex", "structure": bad})
    assert refused.status_code == 422
    assert "stages[0].strokes" in refused.text
    hexapod = client.post("/v1/robots", json={"name": "hex", "structure": hexapod_alone_document()}).json()
    assert hexapod["joint_names"] == ["l1", "l2", "l3", "l4", "l5", "l6"]
    no_urdf = client.get(f"/v1/robots/{hexapod['id']}/parameters", params={"format": "urdf"})
    assert no_urdf.status_code == 422


def test_the_iwr_is_described_too(client: TestClient, robot_id: str) -> None:
    robot = client.get(f"/v1/robots/{robot_id}").json()
    assert robot["model"] == "iwr" and robot["parameter_count"] == 70
    assert robot["joint_names"] == ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6"]
    assert [s["kind"] for s in robot["structure"]["stages"]] == ["serial", "hexapod"]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_csv_campaign_with_the_robots_header(client: TestClient) -> None:

    robot = client.post("/v1/robots", json={"name": "arm", "structure": iiwa_like_document()}).json()
    desc = iiwa_like()
    joints = sample_workspace(desc, 60, seed=3)
    campaign = measure(perturbed_robot(desc, seed=4), joints, seed=5, position_only=True)
    rows = [",".join(f"q{i}" for i in range(1, 8)) + ",x,y,z"]
    for q, p in zip(np.degrees(joints), campaign.positions, strict=True):
        rows.append(",".join(repr(float(v)) for v in [*q, *p]))
    url = f"/v1/robots/{robot['id']}/calibrations"
    made = client.post(url, content="\n".join(rows) + "\n", headers={"content-type": "text/csv"})
    assert made.status_code == 201, made.text
    assert len(made.json()["identifiable"]) == 31
    iwr_header = "q1,q2,q3,q4,l1,l2,l3,l4,l5,l6,x,y,z\n" + ",".join(["1"] * 13) + "\n"
    wrong = client.post(url, content=iwr_header, headers={"content-type": "text/csv"})
    assert wrong.status_code == 422
    ik = client.post(
        f"/v1/robots/{robot['id']}/inverse-kinematics",
        json={"targets": [{"position": [float(v) for v in campaign.positions[0]]}]},
        headers={"accept": "text/csv"},
    )
    assert ik.status_code == 200 and ik.text.startswith("q1,q2,q3,q4,q5,q6,q7\n")


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_csv_outputs_use_the_robots_joint_header(client: TestClient) -> None:
    # A hexapod alone: its joints are the legs, so every CSV the service writes heads them l1 … l6 (robots.md),
    # never q1 … or the IWR's ten columns.
    robot = client.post("/v1/robots", json={"name": "hex-csv", "structure": hexapod_alone_document()}).json()
    legs = "l1,l2,l3,l4,l5,l6"
    csv = {"accept": "text/csv"}
    made = client.post(
        f"/v1/robots/{robot['id']}/pose-designs",
        json={"count": 20, "measurement": "position", "candidate_count": 200},
        headers=csv,
    )
    assert made.status_code == 201, made.text
    lines = made.text.splitlines()
    assert lines[0] == legs and len(lines) == 21
    assert all(len(line.split(",")) == 6 for line in lines[1:])
    design = client.post(
        f"/v1/robots/{robot['id']}/pose-designs", json={"count": 20, "measurement": "position", "candidate_count": 200}
    ).json()
    again = client.get(f"/v1/pose-designs/{design['id']}", headers=csv)
    assert again.status_code == 200 and again.text.splitlines()[0] == legs
    # its poses are the JSON's, under that header
    first = [float(v) for v in again.text.splitlines()[1].split(",")]
    np.testing.assert_allclose(first, design["poses"][0], atol=1e-9)
    # the stored campaign of a calibration, as CSV
    desc = hexapod_alone()
    joints = sample_workspace(desc, 40, seed=7)
    campaign = measure(perturbed_robot(desc, seed=8), joints, seed=9, position_only=True)
    body = {
        "measurements": [
            {"joints": [float(v) for v in q], "position": [float(v) for v in p]}
            for q, p in zip(joints, campaign.positions, strict=True)
        ]
    }
    calibration = client.post(f"/v1/robots/{robot['id']}/calibrations", json=body)
    assert calibration.status_code == 201, calibration.text
    stored = client.get(f"/v1/campaigns/{calibration.json()['campaign_id']}", params={"format": "csv"})
    assert stored.status_code == 200
    rows = stored.text.splitlines()
    assert rows[0] == legs + ",x,y,z" and len(rows) == 41
    np.testing.assert_allclose([float(v) for v in rows[1].split(",")], [*joints[0], *campaign.positions[0]])
    # and the IK answer
    ik = client.post(
        f"/v1/robots/{robot['id']}/inverse-kinematics",
        json={"targets": [{"position": [float(v) for v in campaign.positions[0]]}]},
        headers=csv,
    )
    assert ik.status_code == 200 and ik.text.startswith(legs + "\n")


def _hexapod(**changes: object) -> dict[str, object]:
    document = hexapod_alone_document()
    document["stages"][0].update(changes)
    return document


def _arm(*links: Mapping[str, object], convention: str = "dh") -> dict[str, object]:
    return {"stages": [{"kind": "serial", "convention": convention, "links": list(links)}]}


REVOLUTE = {"joint": "revolute", "range": [-90.0, 90.0]}
RULES = {
    # robots.md's rules between values: models.description.structure names the field as the spec does
    "range lo >= hi": (_arm({**REVOLUTE, "range": [90.0, -90.0]}), "stages[0].links[0].range"),
    "strokes lo >= hi": (_hexapod(strokes=[400.0, 300.0]), "stages[0].strokes"),
    "collinear joints": (_hexapod(base_joints=[[float(k), 0.0, 0.0] for k in range(6)]), "stages[0].base_joints"),
    "no moving joint": (_arm({"joint": "fixed", "a": 10.0}), "stages"),
    "home outside the workspace": (
        _hexapod(home={"position": [0.0, 0.0, 400.0], "orientation": [1.0, 0.0, 0.0, 0.0]}),
        "stages[0].home",
    ),
    "home beyond the strokes": (_hexapod(strokes=[100.0, 200.0]), "stages[0].home"),
    "two hexapods": (
        {"stages": [*hexapod_alone_document()["stages"], *hexapod_alone_document()["stages"]]},
        "stages[1].kind",
    ),
    "beta on a twisted dh link": (_arm({**REVOLUTE, "alpha": 90.0, "beta": 1.0}), "stages[0].links[0].beta"),
    "a fixed link with a range": (_arm(REVOLUTE, {"joint": "fixed", "range": [0.0, 1.0]}), "stages[0].links[1].range"),
    "a quaternion that is not unit": (
        _hexapod(home={"position": [0.0, 0.0, 300.0], "orientation": [2.0, 0.0, 0.0, 0.0]}),
        "stages[0].home.orientation",
    ),
    # the document's shape: the typed schema's errors are named as robots.md names fields
    "unknown stage kind": ({"stages": [{"kind": "gantry"}]}, "stages[0].kind"),
    "unknown key": (_arm({**REVOLUTE, "length": 3.0}), "stages[0].links[0].length"),
    "five platform joints": (
        _hexapod(platform_joints=hexapod_alone_document()["stages"][0]["platform_joints"][:5]),
        "stages[0].platform_joints",
    ),
    "a range of three numbers": (
        _arm({**REVOLUTE, "range": [0.0, 1.0, 2.0]}),
        "stages[0].links[0].range",
    ),
    "no stages": ({"stages": []}, "stages"),
}


def test_every_robots_md_rule_is_a_422_naming_the_field(client: TestClient) -> None:
    for rule, (document, field) in RULES.items():
        answer = client.post("/v1/robots", json={"name": rule, "structure": document})
        assert answer.status_code == 422, (rule, answer.text)
        problem = answer.json()
        assert problem["field"] == field, (rule, problem)
    assert client.get("/v1/robots").json() == []  # nothing was stored


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_the_structure_is_typed_in_the_contract(client: TestClient) -> None:
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    robot = schemas["RobotPublic"]["properties"]["structure"]
    assert robot == {"$ref": "#/components/schemas/StructureDocument", "description": robot["description"]}
    stage = schemas["StructureDocument"]["properties"]["stages"]["items"]
    assert stage["discriminator"]["propertyName"] == "kind"
    for name in ("StructureDocument", "SerialStage", "HexapodStage", "StructureLink", "StructurePose"):
        assert schemas[name]["additionalProperties"] is False, name
    # a hexapod's document comes back with the keys robots.md writes (no nulls for what it leaves out)
    made = client.post("/v1/robots", json={"name": "arm", "structure": _arm(REVOLUTE, {"joint": "fixed", "a": 5.0})})
    links = made.json()["structure"]["stages"][0]["links"]
    assert links[1] == {"joint": "fixed", "a": 5.0, "alpha": 0.0, "d": 0.0, "theta": 0.0}
    assert links[0]["range"] == [-90.0, 90.0] and "beta" not in links[0]
