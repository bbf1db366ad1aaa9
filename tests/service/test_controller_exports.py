"""The calibrated robot as its controller reads it (`?format=dh`, `ur-calibration`, `urdf`) and UR's file in
(`"import"`), each against independent truth: the exported numbers multiplied out here in numpy (or by
yourdfpy), composed with the frames the export's header states, equal the service's forward kinematics."""

from __future__ import annotations

import io
import math
import re
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np
import pytest
import yaml
import yourdfpy
from fastapi.testclient import TestClient

from models import sample_workspace
from models.description.examples import hexapod_alone_document, iiwa_like_document, ur5_like_document
from models.description.structure import description_from_document
from models.description.terms import ModelTerms
from models.formats.urdf import document_from_urdf
from models.simulation import perturbed_robot
from models.transforms import matrix_to_quaternion, quaternion_to_matrix
from tests.frames import rot, shift, xyz_rpy
from tests.models.test_urdf import UR5_URDF
from tests.service.ur5_full_urdf import MOVING, ur5_full_urdf

SEGMENTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
HEADER = re.compile(r"(world_from_root|tip_to_tcp) \[[^\]]*\]: ([-0-9.e+ ]+)")


def _header_frames(text: str) -> dict[str, np.ndarray]:
    found = {}
    for key, numbers in HEADER.findall(text):
        x, y, z, roll, pitch, yaw = (float(v) for v in numbers.split())
        found[key] = xyz_rpy(x, y, z, *np.radians([roll, pitch, yaw]))
    assert set(found) == {"world_from_root", "tip_to_tcp"}, text[:2000]
    return found


def _pose(t: np.ndarray) -> dict[str, list[float]]:
    return {"position": t[:3, 3].tolist(), "orientation": matrix_to_quaternion(t[:3, :3]).tolist()}


def _fk(client: TestClient, robot_id: str, q_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    answer = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": q_deg.tolist()})
    assert answer.status_code == 200, answer.text
    poses = answer.json()["poses"]
    rotations = quaternion_to_matrix(np.array([p["orientation"] for p in poses]))
    return np.array([p["position"] for p in poses]), rotations


def _assert_same_poses(ours: list[np.ndarray], service: tuple[np.ndarray, np.ndarray]) -> None:
    np.testing.assert_allclose([t[:3, 3] for t in ours], service[0], rtol=0, atol=1e-6)  # mm
    np.testing.assert_allclose([t[:3, :3] for t in ours], service[1], rtol=0, atol=1e-9)


def _robot(client: TestClient, body: dict[str, Any]) -> str:
    made = client.post("/v1/robots", json=body)
    assert made.status_code == 201, made.text
    return str(made.json()["id"])


def _calibrated(client: TestClient, robot_id: str, desc: Any, seed: int, terms: ModelTerms | None = None) -> None:
    """A version with the values of a perturbed robot (thesis-sized errors, the base 3 m away): what a
    calibration of that robot would have stored, without running one."""
    model = desc if terms is None else desc.with_terms(terms)
    values = perturbed_robot(model, seed=seed).truth
    table = model.parameters
    body = {
        "parameters": [
            {"name": n, "value": float(v)} for n, v in zip(table.names, table.as_boundary(values), strict=True)
        ]
    }
    answer = client.post(f"/v1/robots/{robot_id}/parameter-versions", json=body)
    assert answer.status_code == 201, answer.text


def _ur_file_fk(text: str, q: np.ndarray) -> list[np.ndarray]:
    kin = yaml.safe_load(text)["kinematics"]
    frames = _header_frames(text)
    out = []
    for qi in q:
        t = frames["world_from_root"].copy()
        for name, angle in zip(SEGMENTS, qi, strict=True):
            s = kin[name]
            t = t @ xyz_rpy(s["x"] * 1e3, s["y"] * 1e3, s["z"] * 1e3, s["roll"], s["pitch"], s["yaw"]) @ rot(2, angle)
        out.append(t @ frames["tip_to_tcp"])
    return out


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_calibrated_ur5s_file_has_its_fk_and_imports_as_a_robot_with_it(client: TestClient) -> None:
    desc = description_from_document(ur5_like_document())
    robot = _robot(client, {"name": "ur5", "structure": ur5_like_document()})
    _calibrated(client, robot, desc, seed=31)
    exported = client.get(f"/v1/robots/{robot}/parameters", params={"format": "ur-calibration"})
    assert exported.status_code == 200, exported.text
    assert exported.headers["content-type"].startswith("application/yaml")
    text = exported.text
    assert text.startswith("# Kinematics of robot 'ur5'") and "\nkinematics:\n  shoulder:\n    x: " in text
    assert re.search(r"\n  hash: calib_\d{19}\n$", text)
    q = sample_workspace(desc, 30, seed=32)
    q_deg = np.degrees(q)
    service = _fk(client, robot, q_deg)
    _assert_same_poses(_ur_file_fk(text, q), service)

    # The file in: a robot whose nominal is that calibration, placed and tooled as the header says.
    frames = _header_frames(text)
    body = {
        "name": "ur5-twin",
        "import": {"format": "ur-calibration", "document": text},
        "base": _pose(frames["world_from_root"]),
        "tool": _pose(frames["tip_to_tcp"]),
    }
    twin = _robot(client, body)
    twin_fk = _fk(client, twin, q_deg)
    np.testing.assert_allclose(twin_fk[0], service[0], rtol=0, atol=1e-6)
    np.testing.assert_allclose(twin_fk[1], service[1], rtol=0, atol=1e-9)
    # …and the twin's own file holds the same six origins (its URDF's joint frames are the file's).
    again = yaml.safe_load(client.get(f"/v1/robots/{twin}/parameters?format=ur-calibration").text)["kinematics"]
    first = yaml.safe_load(text)["kinematics"]
    for name in SEGMENTS:
        np.testing.assert_allclose(list(again[name].values()), list(first[name].values()), atol=1e-12)


def _dh_fk(table: dict[str, Any], q: np.ndarray) -> list[np.ndarray]:
    def frame(f: dict[str, float]) -> np.ndarray:
        angles = np.radians([f["roll_deg"], f["pitch_deg"], f["yaw_deg"]])
        return xyz_rpy(f["x_mm"], f["y_mm"], f["z_mm"], *angles)

    out = []
    for qi in q:
        t, readings = frame(table["base"]), iter(qi)
        for link in table["links"]:
            reading = next(readings) if link["type"] != "fixed" else 0.0
            th = math.radians(link["theta_deg"]) + (reading if link["type"] == "revolute" else 0.0)
            d = link["d_mm"] + (reading if link["type"] == "prismatic" else 0.0)
            al, beta = math.radians(link["alpha_deg"]), math.radians(link["beta_deg"] or 0.0)
            if link["convention"] == "dh":
                t = t @ rot(2, th) @ shift(0, 0, d) @ shift(link["a_mm"], 0, 0) @ rot(0, al) @ rot(1, beta)
            else:
                t = t @ rot(0, al) @ rot(1, beta) @ shift(link["a_mm"], 0, 0) @ rot(2, th) @ shift(0, 0, d)
        out.append(t @ frame(table["tool"]))
    return out


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("document", [ur5_like_document("dh-beta"), iiwa_like_document()], ids=["dh", "mdh"])
def test_the_dh_table_multiplies_out_to_the_fk(client: TestClient, document: dict[str, Any]) -> None:
    desc = description_from_document(document)
    robot = _robot(client, {"name": "arm", "structure": document})
    _calibrated(client, robot, desc, seed=41)
    answer = client.get(f"/v1/robots/{robot}/parameters", params={"format": "dh"})
    assert answer.status_code == 200 and answer.headers["content-type"].startswith("application/vnd.iwr.dh-table+json")
    table = answer.json()
    assert table["format"] == "dh" and table["version"] == 2 and "world" in table["frame"]
    assert {link["convention"] for link in table["links"]} == {document["stages"][0]["convention"]}
    q = sample_workspace(desc, 30, seed=42)
    _assert_same_poses(_dh_fk(table, q), _fk(client, robot, np.degrees(q)))
    nominal = client.get(f"/v1/robots/{robot}/parameters", params={"format": "dh", "version": 1}).json()
    assert nominal["version"] == 1 and nominal["base"]["x_mm"] == 0.0


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_what_an_export_cannot_hold_exactly_is_refused_with_the_reason(client: TestClient) -> None:
    hexapod = _robot(client, {"name": "hexapod", "structure": hexapod_alone_document()})
    arm7 = _robot(client, {"name": "iiwa", "structure": iiwa_like_document()})
    ur5 = _robot(client, {"name": "ur5", "structure": ur5_like_document()})
    _calibrated(client, ur5, description_from_document(ur5_like_document()), 51, ModelTerms(compliance=True))
    iwr = _robot(client, {"name": "iwr"})
    cases = [
        (hexapod, "dh", "not_serial"),
        (hexapod, "ur-calibration", "not_serial"),
        (iwr, "dh", "not_serial"),  # the IWR: a carriage under a hexapod
        (arm7, "ur-calibration", "not_6r"),
        (ur5, "dh", "model_terms"),
        (ur5, "ur-calibration", "model_terms"),
        (ur5, "urdf", "model_terms"),
    ]
    for robot, format, reason in cases:
        answer = client.get(f"/v1/robots/{robot}/parameters", params={"format": format})
        assert answer.status_code == 422, (format, reason, answer.text)
        assert answer.json()["field"] == "format" and answer.json()["reason"] == reason, answer.json()
    # The version before the terms exports.
    assert client.get(f"/v1/robots/{ur5}/parameters", params={"format": "dh", "version": 1}).status_code == 200


def _without(tree: ET.Element, moving: set[str]) -> list[tuple[str, dict[str, str], str]]:
    """Every element in document order (tag, attributes, text) but the `<origin>` of the `moving` joints."""
    out = []
    for joint_or_other in tree.iter():
        out.append((joint_or_other.tag, dict(joint_or_other.attrib), (joint_or_other.text or "").strip()))
    skip = {id(o) for j in tree.findall("joint") if j.get("name") in moving for o in j.findall("origin")}
    return [e for e, el in zip(out, tree.iter(), strict=True) if id(el) not in skip]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_an_imported_urdf_comes_back_with_only_its_joint_origins_calibrated(client: TestClient) -> None:
    text = ur5_full_urdf()
    robot = _robot(client, {"name": "ur5--urdf", "urdf": text, "base_link": "base_link", "tip_link": "tool0"})
    desc = description_from_document(document_from_urdf(text, "base_link", "tool0"))
    _calibrated(client, robot, desc, seed=61)
    answer = client.get(f"/v1/robots/{robot}/parameters", params={"format": "urdf"})
    assert answer.status_code == 200 and answer.headers["content-type"].startswith("application/xml")
    exported = answer.text
    before, after = ET.fromstring(text.encode()), ET.fromstring(exported.encode())
    assert _without(after, set(MOVING)) == _without(before, set(MOVING))
    origins = {
        str(j.get("name")): [tree.find(f"joint[@name='{j.get('name')}']/origin") for tree in (before, after)]
        for j in before.findall("joint")
    }
    changed = [name for name, (b, a) in origins.items() if b is None or a is None or b.attrib != a.attrib]
    assert sorted(changed) == sorted(MOVING)
    assert exported.count("<transmission") == 6 and 'filename="libgazebo_ros_control.so"' in exported

    frames = _header_frames(exported)
    q = sample_workspace(desc, 30, seed=62)
    model = yourdfpy.URDF.load(io.BytesIO(exported.encode()), load_meshes=False, build_collision_scene_graph=False)
    ours = []
    for qi in q:
        model.update_cfg(dict(zip(MOVING, qi, strict=True)))
        t = np.array(model.get_transform(frame_to="tool0", frame_from="base_link"))
        t[:3, 3] *= 1000.0
        ours.append(frames["world_from_root"] @ t @ frames["tip_to_tcp"])
    service = _fk(client, robot, np.degrees(q))
    _assert_same_poses(ours, service)
    # The same robot as UR's file: its axes along y turned onto z, the FK the same.
    ur_file = client.get(f"/v1/robots/{robot}/parameters", params={"format": "ur-calibration"})
    assert ur_file.status_code == 200, ur_file.text
    _assert_same_poses(_ur_file_fk(ur_file.text, q), service)


@pytest.mark.parametrize(
    ("document", "field"),
    [
        ("kinematics: [1, 2", "import.document"),
        (
            "kinematics:\n  shoulder: {x: 0, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}\n",
            "import.document.kinematics.upper_arm",
        ),
        (
            "kinematics:\n"
            + "".join(f"  {s}: {{x: 0, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}}\n" for s in SEGMENTS).replace(
                "wrist_2: {x: 0", "wrist_2: {x: zero"
            ),
            "import.document.kinematics.wrist_2.x",
        ),
    ],
)
def test_a_ur_file_that_cannot_be_read_is_a_422_naming_the_key(client: TestClient, document: str, field: str) -> None:
    answer = client.post(
        "/v1/robots", json={"name": "ur", "import": {"format": "ur-calibration", "document": document}}
    )
    assert answer.status_code == 422 and answer.json()["field"] == field, answer.text
    both = {"name": "ur", "urdf": UR5_URDF, "import": {"format": "ur-calibration", "document": document}}
    assert client.post("/v1/robots", json=both).json()["field"] == "import"
    assert client.get("/v1/robots").json() == []


def test_a_tool_given_with_a_urdf_goes_after_its_tip(client: TestClient) -> None:
    body = {"urdf": UR5_URDF, "base_link": "world", "tip_link": "tool0"}
    plain = _robot(client, {"name": "ur5", **body})
    tool = {"position": [0.0, 0.0, 100.0], "orientation": [1.0, 0.0, 0.0, 0.0]}
    base = {"position": [1000.0, 0.0, 0.0], "orientation": [math.cos(0.25), 0.0, 0.0, math.sin(0.25)]}
    tooled = _robot(client, {"name": "ur5-tool", **body, "tool": tool, "base": base})
    q_deg = np.degrees(sample_workspace(description_from_document(document_from_urdf(UR5_URDF, "world", "tool0")), 10))
    p, r = _fk(client, plain, q_deg)
    p2, r2 = _fk(client, tooled, q_deg)
    b = shift(1000.0, 0, 0) @ rot(2, 0.5)  # world <- the URDF's world link
    for i in range(len(q_deg)):
        t = np.eye(4)
        t[:3, :3], t[:3, 3] = r[i], p[i]
        expected = b @ t @ shift(0, 0, 100.0)
        np.testing.assert_allclose(p2[i], expected[:3, 3], atol=1e-9)
        np.testing.assert_allclose(r2[i], expected[:3, :3], atol=1e-12)
    # PATCH means the same frames as POST.
    assert client.patch(f"/v1/robots/{plain}", json={"tool": tool, "base": base}).status_code == 200
    p3, r3 = _fk(client, plain, q_deg)
    np.testing.assert_allclose(p3, p2, atol=1e-9)
    np.testing.assert_allclose(r3, r2, atol=1e-12)


def test_a_continuous_joint_turns_past_half_a_turn(client: TestClient) -> None:
    robot = _robot(client, {"name": "ur5", "urdf": UR5_URDF, "base_link": "world", "tip_link": "tool0"})
    p, r = _fk(
        client, robot, np.array([[10.0, -40.0, 30.0, 20.0, 50.0, 270.0], [10.0, -40.0, 30.0, 20.0, 50.0, -90.0]])
    )
    np.testing.assert_allclose(p[0], p[1], atol=1e-9)
    np.testing.assert_allclose(r[0], r[1], atol=1e-12)
