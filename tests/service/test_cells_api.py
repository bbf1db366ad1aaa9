"""A robot's cell over HTTP (issue 46): stored and versioned, read back with its effective geometry, refused with
a 422 naming the field, used by pose designs and by the check of a pose list; each verdict against the
independent, hand-written check of tests/models/cell_reference.py (no collision library)."""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from iwr_client.errors import ApiError
from models.cell import Box, Cell, Obstacle, Tracker, cell_for
from models.description.examples import UR5_DH, ur5_like_document
from models.description.robot import RobotDescription
from models.description.structure import description_from_document
from models.workspace import sample_workspace
from service.compute import limits
from tests.models.cell_reference import dh_frames, reference_verdicts
from tests.service.helpers import InProcess

TABLE: dict[str, Any] = {"name": "table", "kind": "box", "size_mm": [1500, 1500, 40], "position_mm": [0, 0, -21]}
FIXTURE: dict[str, Any] = {
    "name": "fixture",
    "kind": "box",
    "size_mm": [300, 300, 300],
    "position_mm": [500, 300, 150],
    "rotation_vector_deg": [0, 0, float(np.degrees(0.2))],
}
TRACKER: dict[str, Any] = {"position_mm": [2500, 0, 600], "acceptance_deg": 60}
CELL: dict[str, Any] = {"obstacles": [TABLE, FIXTURE], "tracker": TRACKER}


def the_same_cell(desc: RobotDescription) -> Cell:
    """CELL built directly in the models (mm, radians), not through the service's conversion."""
    table = Obstacle("table", Box(1500.0, 1500.0, 40.0), (0.0, 0.0, -21.0, 0.0, 0.0, 0.0))
    fixture = Obstacle("fixture", Box(300.0, 300.0, 300.0), (500.0, 300.0, 150.0, 0.0, 0.0, 0.2))
    return cell_for(desc, obstacles=(table, fixture), tracker=Tracker((2500.0, 0.0, 600.0), acceptance=np.radians(60)))


@pytest.fixture
def ur5(client: TestClient) -> tuple[str, RobotDescription]:
    """A UR5-like robot and its description as the service states it (its structure document read back)."""
    made = client.post("/v1/robots", json={"name": "ur5-cell", "structure": ur5_like_document()})
    assert made.status_code == 201, made.text
    robot_id = str(made.json()["id"])
    document = client.get(f"/v1/robots/{robot_id}/structure").json()
    return robot_id, description_from_document(document)


def test_a_cell_round_trips_with_its_effective_geometry(client: TestClient, ur5: tuple[str, RobotDescription]) -> None:
    robot_id, _ = ur5
    etag = client.get(f"/v1/robots/{robot_id}").headers["ETag"]
    mesh = {"name": "guard", "kind": "mesh", "vertices_mm": [[900, 0, 0], [1000, 0, 0], [900, 100, 0], [900, 0, 100]]}
    mesh["faces"] = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]]
    body = {**CELL, "obstacles": [TABLE, FIXTURE, mesh], "links": {"link2": {"capsule_radius_mm": 55}}}
    put = client.put(f"/v1/robots/{robot_id}/cell", json=body, headers={"If-Match": etag})
    assert put.status_code == 200, put.text
    assert put.headers["ETag"] != etag  # a cell write is a robot write
    got = client.get(f"/v1/robots/{robot_id}/cell").json()
    assert got == put.json()
    assert got["version"] == 1 and got["geometry_source"] == "links"
    assert got["cell"]["obstacles"][2]["faces"] == mesh["faces"]
    assert got["cell"]["tracker"]["range_min_mm"] == 1000  # the defaults, shown back
    radii: dict[str, set[float]] = {}
    for shape in got["geometry"]:
        radii.setdefault(shape["body"], set()).add(shape["radius_mm"])
        assert shape["origin"] == ("override" if shape["body"] == "link2" else "default")
    # The default capsule radius by its rule, from the DH table: clamp(0.1 (|a| + |d|), 25, 80) mm
    for k, row in enumerate(UR5_DH):
        expected = 55.0 if k == 1 else min(max(0.1 * (abs(row["a"]) + abs(row["d"])), 25.0), 80.0)
        assert len(radii[f"link{k + 1}"]) == 1
        assert radii[f"link{k + 1}"].pop() == pytest.approx(expected)
    assert radii["tool"] == {20.0}
    allowed = {tuple(p["solids"]): p["why"] for p in got["allowed"]}
    assert allowed[("link1", "link2")] == "adjacent" and allowed[("link1", "table")] == "always touching"
    stale = client.put(f"/v1/robots/{robot_id}/cell", json=CELL, headers={"If-Match": etag})
    assert stale.status_code == 412


def test_versions_are_kept_and_delete_ends_the_cell(client: TestClient, ur5: tuple[str, RobotDescription]) -> None:
    robot_id, _ = ur5
    url = f"/v1/robots/{robot_id}/cell"
    assert client.get(url).status_code == 404
    assert client.put(url, json=CELL).status_code == 200
    assert client.put(url, json={**CELL, "clearance_mm": 25}).status_code == 200
    assert client.delete(url).status_code == 204
    versions = client.get(f"{url}/versions").json()
    assert [(v["version"], v["ended"], v["obstacles"], v["instruments"]) for v in versions] == [
        (1, False, 2, ["tracker"]),
        (2, False, 2, ["tracker"]),
        (3, True, 0, []),
    ]
    assert client.get(url).status_code == 404
    assert client.get(url, params={"version": 1}).json()["cell"]["clearance_mm"] == 10
    assert client.get(url, params={"version": 2}).json()["cell"]["clearance_mm"] == 25
    assert client.get(url, params={"version": 3}).status_code == 404
    assert client.get(url, params={"version": 4}).status_code == 404
    assert client.delete(url).status_code == 404  # nothing left to end
    trail = client.get("/v1/audit", params={"robot_id": robot_id}).json()
    actions = [e["action"] for e in (trail["events"] if isinstance(trail, dict) else trail)]
    assert actions[-3:] == ["cell.updated", "cell.updated", "cell.ended"]


BAD: list[tuple[dict[str, Any], str]] = [
    ({"obstacles": [{**TABLE, "size_mm": [1500, -1, 40]}]}, "size_mm"),
    ({"obstacles": [{**TABLE, "size_mm": [1500, 0, 40]}]}, "size_mm"),
    ({"tracker": {**TRACKER, "range_min_mm": 5000, "range_max_mm": 4000}}, "range_min_mm"),
    ({"tracker": {**TRACKER, "acceptance_deg": 0}}, "acceptance_deg"),
    ({"obstacles": [{**TABLE, "name": f"box{k}"} for k in range(limits.CELL_OBSTACLES_MAX + 1)]}, "obstacles"),
    ({"obstacles": [{"name": "m", "kind": "mesh", "vertices_mm": [[0, 0, 0]] * 3, "faces": [[0, 1, 3]]}]}, "faces"),
    ({"links": {"link9": {"capsule_radius_mm": 30}}}, "link9"),
    ({"links": {"link2": {"capsule_radius_mm": 30, "shapes": [{"kind": "sphere", "radius_mm": 5}]}}}, "one of"),
    ({"links": {"link2": {"shapes": [{"kind": "sphere", "radius_mm": 5}], "frame": "link4"}}}, "link2.frame"),
    ({"obstacles": [{**TABLE, "name": "link1"}]}, "obstacles"),
    ({"allowed": [["link1", "nowhere"]]}, "nowhere"),
    ({"clearance_mm": -1}, "clearance_mm"),
]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(("body", "named"), BAD)
def test_bad_cells_are_422s_naming_the_field(
    client: TestClient, ur5: tuple[str, RobotDescription], body: dict[str, Any], named: str
) -> None:
    answer = client.put(f"/v1/robots/{ur5[0]}/cell", json=body)
    assert answer.status_code == 422, answer.text
    assert named in answer.text
    assert client.get(f"/v1/robots/{ur5[0]}/cell/versions").json() == []  # nothing stored


def test_non_finite_numbers_are_422s(client: TestClient, ur5: tuple[str, RobotDescription]) -> None:
    text = json.dumps({"tracker": TRACKER}).replace("2500", "NaN")
    answer = client.put(f"/v1/robots/{ur5[0]}/cell", content=text, headers={"Content-Type": "application/json"})
    assert answer.status_code == 422 and "position_mm" in answer.text


@pytest.mark.slow  # ~1 s of CPU: parsing the 20 002 triangles
def test_too_many_mesh_faces_in_all_are_a_422(client: TestClient, ur5: tuple[str, RobotDescription]) -> None:
    url = f"/v1/robots/{ur5[0]}/cell"
    half = limits.CELL_MESH_FACES_MAX // 2 + 1
    mesh = {"kind": "mesh", "vertices_mm": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]] * half}
    two = {"obstacles": [{**mesh, "name": "a"}, {**mesh, "name": "b"}]}
    answer = client.put(url, json=two)
    assert answer.status_code == 422 and f"{2 * half} triangles" in answer.text


def _verdicts_agree(desc: RobotDescription, q_rad: np.ndarray, answered: list[dict[str, Any]]) -> int:
    """The service's verdicts against the hand-written reference where the reference is unambiguous; how many
    were compared."""
    reference, ambiguous = reference_verdicts(desc, the_same_cell(desc), q_rad, dh_frames(desc, q_rad))
    compared = 0
    for k, pose in enumerate(answered):
        if ambiguous[k]:
            continue
        assert pose["feasible"] == (reference[k] == ""), (k, pose, reference[k])
        assert (pose["reason"] or "") == reference[k]
        compared += 1
    return compared


def test_the_check_answers_each_pose_as_the_independent_check(
    client: TestClient, ur5: tuple[str, RobotDescription]
) -> None:
    robot_id, desc = ur5
    assert client.put(f"/v1/robots/{robot_id}/cell", json=CELL).status_code == 200
    q = sample_workspace(desc, 60, seed=4)
    poses = [*np.degrees(q).tolist(), [0, 0, 0, 0, 0, 200]]  # the last: q6 past its 180°
    answer = client.post(f"/v1/robots/{robot_id}/cell/check", json={"poses": poses})
    assert answer.status_code == 200, answer.text
    found = answer.json()
    assert found["cell_version"] == 1
    assert found["poses"][-1] == {"feasible": False, "reason": "joint_limits", "detail": "joint q6 outside its range"}
    assert _verdicts_agree(desc, q, found["poses"][:-1]) >= 50
    refused = [p["reason"] for p in found["poses"] if not p["feasible"]]
    assert found["feasible"] == len(poses) - len(refused)
    assert found["refused"] == {r: refused.count(r) for r in set(refused)}
    assert {"incidence", "cell_collision"} <= set(found["refused"])
    # A cell sent with the request: the same verdicts, no stored version
    inline = client.post(f"/v1/robots/{robot_id}/cell/check", json={"poses": poses, "cell": CELL}).json()
    assert inline["cell_version"] is None and inline["poses"] == found["poses"]


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_a_check_or_design_with_the_stored_cell_needs_one(
    client: TestClient, ur5: tuple[str, RobotDescription]
) -> None:
    robot_id, _ = ur5
    check = client.post(f"/v1/robots/{robot_id}/cell/check", json={"poses": [[0, -90, 80, -90, 90, 0]]})
    assert check.status_code == 422 and "has no cell" in check.text
    design = client.post(
        f"/v1/robots/{robot_id}/pose-designs",
        json={"count": 30, "measurement": "position", "candidate_count": 100, "cell": "stored"},
    )
    assert design.status_code == 422 and "has no cell" in design.text


def test_a_design_in_a_cell_counts_the_checks_in_its_cost(
    client: TestClient, ur5: tuple[str, RobotDescription]
) -> None:
    # 2 000 feasible candidates are ~20 000 sampled and checked: over the synchronous budget, a job's work
    url = f"/v1/robots/{ur5[0]}/pose-designs"
    body = {"count": 30, "measurement": "position", "cell": CELL}
    answer = client.post(url, json=body)
    assert answer.status_code == 422 and answer.json()["use_async"] is True, answer.text
    assert "in a cell (20000 candidates checked)" in answer.json()["detail"]
    assert client.post(url, json={**body, "candidate_count": 300}).status_code == 201


@pytest.mark.slow  # ~1.5 s of CPU: a design of 30 poses among 300 feasible candidates and their reference check
def test_a_design_with_the_stored_cell_chooses_only_feasible_poses(
    client: TestClient, ur5: tuple[str, RobotDescription]
) -> None:
    robot_id, desc = ur5
    assert client.put(f"/v1/robots/{robot_id}/cell", json=CELL).status_code == 200
    body = {"count": 30, "measurement": "position", "candidate_count": 300, "seed": 2, "cell": "stored"}
    answer = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body)
    assert answer.status_code == 201, answer.text
    report = answer.json()
    cell = report["cell"]
    assert cell["version"] == 1
    assert cell["checked"] == report["constraints"]["offered"]
    assert cell["refused"] == report["constraints"]["excluded"]
    assert cell["checked"] - sum(cell["refused"].values()) == cell["feasible"] >= report["candidates"] == 300
    assert {"incidence", "cell_collision"} <= set(cell["refused"])
    q = np.radians(np.asarray(report["poses"]))
    reference, _ = reference_verdicts(desc, the_same_cell(desc), q, dh_frames(desc, q))
    assert reference == [""] * 30
    assert report["bound"]["certified"] and report["efficiency"] > 0.9


def test_the_client_has_a_method_per_endpoint(client: TestClient, ur5: tuple[str, RobotDescription]) -> None:
    robot_id, desc = ur5
    iwr = InProcess(client)
    etag = client.get(f"/v1/robots/{robot_id}").headers["ETag"]
    assert iwr.put_cell(robot_id, CELL, if_match=etag)["version"] == 1
    with pytest.raises(ApiError) as stale:
        iwr.put_cell(robot_id, CELL, if_match=etag)
    assert stale.value.status == 412
    assert iwr.cell(robot_id)["cell"]["tracker"]["acceptance_deg"] == 60
    poses = np.degrees(sample_workspace(desc, 5, seed=1)).tolist()
    checked = iwr.check_cell(robot_id, poses)
    assert checked["cell_version"] == 1 and len(checked["poses"]) == 5
    iwr.delete_cell(robot_id)
    assert [v["ended"] for v in iwr.cell_versions(robot_id)] == [False, True]
    assert iwr.cell(robot_id, version=1)["version"] == 1
