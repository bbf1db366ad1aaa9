"""The parameters export (JSON and CSV by Accept, any version) re-imports to the same forward kinematics: exported
from a calibrated robot and imported into a new one (POST …/parameter-versions), the new robot's FK equals the
original's (to 1e-9 mm: angles cross degrees and back, which can move the last bit of a radian value)."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from tests.service.helpers import records

DESC = iwr()


def _fk(client: TestClient, robot_id: str, joints: list[list[float]]) -> list[dict[str, list[float]]]:
    answer = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": joints})
    assert answer.status_code == 200, answer.text
    return list(answer.json()["poses"])


@pytest.mark.parametrize("media", ["application/json", "text/csv"])
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_an_export_reimports_to_the_same_fk(client: TestClient, robot_id: str, media: str) -> None:
    sim = perturbed_robot(DESC, seed=111)
    recs = records(DESC, sim, sample_workspace(DESC, 40, seed=112), seed=113)
    assert client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs}).status_code == 201
    exported = client.get(f"/v1/robots/{robot_id}/parameters", headers={"Accept": media})
    assert exported.status_code == 200 and exported.headers["content-type"].startswith(media)

    other = client.post("/v1/robots", json={"name": "twin"}).json()["id"]
    imported = client.post(
        f"/v1/robots/{other}/parameter-versions", content=exported.content, headers={"Content-Type": media}
    )
    assert imported.status_code == 201, imported.text
    assert imported.json()["provenance"] == "import" and imported.json()["version"] == 2
    joints = (sample_workspace(DESC, 20, seed=114) * DESC.joint_to_boundary).tolist()
    twin, original = _fk(client, other, joints), _fk(client, robot_id, joints)
    for key, tolerance in (("position", 1e-9), ("orientation", 1e-14)):
        np.testing.assert_allclose([p[key] for p in twin], [p[key] for p in original], rtol=0, atol=tolerance)
    ours = client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]
    theirs = client.get(f"/v1/robots/{other}/parameters").json()["parameters"]
    assert [p["identifiable"] for p in theirs] == [p["identifiable"] for p in ours]
    for a, b in zip(theirs, ours, strict=True):
        assert a["value"] == pytest.approx(b["value"], rel=1e-15, abs=1e-15)
        assert (a["std_error"] is None) == (b["std_error"] is None)


def test_export_formats_versions_and_bad_imports(client: TestClient, robot_id: str) -> None:
    as_csv = client.get(f"/v1/robots/{robot_id}/parameters?version=1", headers={"Accept": "text/csv"}).text
    rows = list(csv.DictReader(io.StringIO(as_csv)))
    assert len(rows) == 70 and rows[0] == {
        "name": "base.x",
        "value": "0.0",
        "unit": "mm",
        "nominal": "0.0",
        "std_error": "",
        "identifiable": "",
    }
    assert client.get(f"/v1/robots/{robot_id}/parameters", headers={"Accept": "text/*"}).text == as_csv
    assert client.get(f"/v1/robots/{robot_id}/parameters", headers={"Accept": "*/*"}).json()["version"] == 1
    refused = client.get(f"/v1/robots/{robot_id}/parameters", headers={"Accept": "application/xml"})
    assert refused.status_code == 406 and refused.json()["offered"] == ["application/json", "text/csv"]
    assert client.get(f"/v1/robots/{robot_id}/parameters?version=5").status_code == 404

    url = f"/v1/robots/{robot_id}/parameter-versions"
    params = client.get(f"/v1/robots/{robot_id}/parameters").json()
    short = {"parameters": params["parameters"][:-1]}
    answer = client.post(url, json=short)
    assert answer.status_code == 422 and answer.json()["field"] == "parameters"
    unknown = {"parameters": [*params["parameters"][:-1], {**params["parameters"][-1], "name": "tool.w"}]}
    assert client.post(url, json=unknown).json()["field"] == "parameters[69].name"
    wrong_unit = {"parameters": [{**params["parameters"][0], "unit": "deg"}, *params["parameters"][1:]]}
    assert client.post(url, json=wrong_unit).json()["field"] == "parameters[0].unit"
    nan = as_csv.replace("base.x,0.0", "base.x,nan")
    assert client.post(url, content=nan, headers={"Content-Type": "text/csv"}).status_code == 422
    assert client.post(url, content="a,b\n1,2\n", headers={"Content-Type": "text/csv"}).status_code == 400
    assert client.post(url, content=b"x", headers={"Content-Type": "text/plain"}).status_code == 415
    assert len(client.get(url).json()) == 1  # nothing stored


def test_pose_designs_are_listed(client: TestClient, robot_id: str) -> None:
    body = {"count": 12, "criterion": "D", "candidate_count": 60, "seed": 3}
    made = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body).json()
    listed = client.get(f"/v1/robots/{robot_id}/pose-designs").json()
    assert listed == [
        {
            "id": made["id"],
            "robot_id": robot_id,
            "created_at": made["created_at"],
            "criterion": "D",
            "measurement": "pose",
            "count": 12,
            "value": made["value"],
        }
    ]
    assert client.get("/v1/robots/nope/pose-designs").status_code == 404
