"""Issue 48's probe inputs that answered 500 (or a 4xx only after seconds), each now a 4xx problem naming what to
fix. Time is this process's CPU time (the TestClient's app runs here) and memory tracemalloc's peak, so the
assertions hold on a busy machine; nothing is stored."""

from __future__ import annotations

import pytest
import yaml
from fastapi.testclient import TestClient

from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.ur_kinematics import MAX_FLOW_DEPTH, flow_depth, read_kinematics
from models.formats.urdf import MAX_OFFSET_M, document_from_urdf
from tests.models.test_urdf_hostile import LIMIT, urdf
from tests.service.helpers import cost

UR_FILE = """kinematics:
  shoulder: {x: 0, y: 0, z: 0.1625, roll: 0, pitch: 0, yaw: 0}
  upper_arm: {x: 0, y: 0, z: 0, roll: 1.570796327, pitch: 0, yaw: 0}
  forearm: {x: -0.425, y: 0, z: 0, roll: 0, pitch: 0, yaw: 0}
  wrist_1: {x: -0.3922, y: 0, z: 0.1333, roll: 0, pitch: 0, yaw: 0}
  wrist_2: {x: 0, y: -0.0997, z: 0, roll: 1.570796327, pitch: 0, yaw: 0}
  wrist_3: {x: 0, y: 0.0996, z: 0, roll: 1.570796327, pitch: 3.141592653589793, yaw: 3.141592653589793}
  hash: calib_12345
"""
"""A UR5e's file in ur_description's flow style (`default_kinematics.yaml` writes the same numbers as blocks)."""


def _two_joints(origin: str = "0 0 0", axis: str = "0 0 1", kind: str = "revolute", limit: str = LIMIT) -> str:
    return urdf(
        ["l0", "l1", "l2"],
        [
            f'<joint name="shoulder" type="{kind}"><parent link="l0"/><child link="l1"/>'
            f'<origin xyz="{origin}" rpy="0 0 0"/><axis xyz="{axis}"/>{limit}</joint>',
            f'<joint name="elbow" type="revolute"><parent link="l1"/><child link="l2"/>'
            f'<origin xyz="0 0 0.4"/><axis xyz="0 1 0"/>{LIMIT}</joint>',
        ],
    )


@pytest.fixture
def warm(client: TestClient) -> TestClient:
    """The URDF reader imported (yourdfpy and trimesh: ~1.7 s once per process, not the attack's cost)."""
    assert client.post(
        "/v1/robots", json={"name": "ok", "urdf": _two_joints(), "base_link": "l0", "tip_link": "l2"}
    ).is_success
    return client


def test_a_urdf_origin_of_1e308_is_a_422_naming_the_joint_and_element(warm: TestClient) -> None:
    # The probe's 500: 1e308 m overflowed to infinity in mm, then an internal assertion of the frame builder.
    for origin in ("1e308 0 0", "0 -1e300 0", "0 0 1e4"):
        with cost() as spent:
            answer = warm.post(
                "/v1/robots",
                json={"name": "far", "urdf": _two_joints(origin), "base_link": "l0", "tip_link": "l2"},
            )
        assert answer.status_code == 422, answer.text
        problem = answer.json()
        assert problem["field"] == "urdf" and "joint 'shoulder' <origin xyz>" in problem["detail"], problem
        assert f"at most {MAX_OFFSET_M:g} m" in problem["detail"]
        assert spent["cpu_s"] < 1.0 and spent["peak_mb"] < 50, spent
    assert [r["name"] for r in warm.get("/v1/robots").json()] == ["ok"]


def test_urdf_numbers_at_the_edges_of_floats() -> None:
    # A prismatic limit of 1e308 m: refused naming the element, as an origin is.
    limit = '<limit lower="-1e308" upper="1e308" effort="0" velocity="0"/>'
    with pytest.raises(InvalidInput, match=r"joint 'shoulder' <limit lower>: 1e\+308 m"):
        document_from_urdf(_two_joints(kind="prismatic", limit=limit), "l0", "l2")
    # An axis of huge components is a direction (its norm overflowed: a LinAlgError, a 500): the same robot as
    # the unit axis.
    huge, unit = (document_from_urdf(_two_joints(axis=a), "l0", "l2") for a in ("1e200 1e200 0", "1 1 0"))
    assert huge == unit
    # A revolute joint's limits beyond ten turns are cut to ten turns (revolute kinematics are periodic); NaN is
    # still refused by the structure reader.
    wide = '<limit lower="-1e300" upper="1e300" effort="0" velocity="0"/>'
    links = document_from_urdf(_two_joints(limit=wide), "l0", "l2")["stages"][0]["links"]
    assert links[0]["range"] == [-3600.0, 3600.0]
    description_from_document(document_from_urdf(_two_joints(limit=wide), "l0", "l2"))
    nan = '<limit lower="nan" upper="1" effort="0" velocity="0"/>'
    with pytest.raises(InvalidInput, match="finite"):
        description_from_document(document_from_urdf(_two_joints(limit=nan), "l0", "l2"))


def test_a_multipart_boundary_over_256_characters_is_a_400(client: TestClient, robot_id: str) -> None:
    # The probe's 500: python_multipart raised its FormParserError where it starts, inside the route.
    for length, status in ((256, 400), (257, 400), (5000, 400)):
        boundary = "b" * length
        body = (
            f'--{boundary}\r\nContent-Disposition: form-data; name="records"; filename="r.csv"\r\n\r\n'
            f"q1,x\n1,2\n\r\n--{boundary}--\r\n"
        )
        answer = client.post(
            f"/v1/robots/{robot_id}/calibrations",
            content=body,
            headers={"content-type": f"multipart/form-data; boundary={boundary}"},
        )
        assert answer.status_code == status, answer.text
        detail = answer.json()["detail"]
        if length > 256:
            assert f"multipart boundary has {length} characters; at most 256" in detail
        else:  # read, and refused for what the file lacks
            assert "no column" in detail


def test_a_descriptions_part_nested_100_000_deep_is_a_400(client: TestClient, robot_id: str) -> None:
    # json.loads recursed into a RecursionError (a 500).
    files = {"records": ("r.csv", b"kind,q1,x\n"), "descriptions": ("d.json", b"[" * 100_000)}
    answer = client.post(f"/v1/robots/{robot_id}/calibrations", files=files)
    assert answer.status_code == 400, answer.text
    assert "nested 100000 levels deep; at most 32" in answer.json()["detail"]


def test_a_ur_file_of_30_000_brackets_is_a_422_before_yaml_reads_it(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 0.84 s of CPU here (5.8 s on the loaded probe machine) in PyYAML's recursion before its 422. The proof is that
    # PyYAML never sees the text; the CPU bound is loose (the process's other threads count in it under load).
    def must_not_parse(text: str) -> object:
        raise AssertionError("PyYAML was asked to read a file the bracket count refuses")

    monkeypatch.setattr(yaml, "safe_load", must_not_parse)
    with cost() as spent:
        answer = client.post(
            "/v1/robots", json={"name": "ur", "import": {"format": "ur-calibration", "document": "[" * 30_000}}
        )
    assert answer.status_code == 422, answer.text
    problem = answer.json()
    assert problem["field"] == "import.document" and f"nests at most {MAX_FLOW_DEPTH}" in problem["detail"]
    assert spent["cpu_s"] < 0.6 and spent["peak_mb"] < 20, spent


def test_the_flow_depth_is_counted_as_yaml_nests() -> None:
    # The UR file in flow style nests 2 deep (kinematics' segments); comments do not count; each level does.
    assert flow_depth(UR_FILE) == 1
    assert len(read_kinematics(UR_FILE)) == 6
    assert flow_depth("a: [1, [2, {b: [3]}]]  # [[[[[[") == 4
    assert flow_depth("#" + "[" * 100 + "\nx: 1") == 0
    deep = "x: " + "[" * (MAX_FLOW_DEPTH + 1) + "]" * (MAX_FLOW_DEPTH + 1)
    with pytest.raises(InvalidInput, match=f"nested {MAX_FLOW_DEPTH + 1} deep"):
        read_kinematics(deep)
