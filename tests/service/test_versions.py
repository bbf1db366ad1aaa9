"""Parameter versions (list, diff, restore, import), ETags with If-Match, PATCH, the audit trail, campaigns."""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import httpx
import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import Registry, forward_kinematics, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.http.security import digest
from tests.service.conftest import make_client
from tests.service.helpers import finished_job, records

DESC = iwr()


# Named keys, as a plant configures them (name:scope:sha256): the audit trail records the name, never the key.
KEYS = {"metrology": "write", "ops": "admin", "alice": "write", "bob": "admin", "tester": "admin"}


def _key(name: str) -> str:
    return f"key-of-{name}-0123456789abcdef"


@pytest.fixture
def client(database_url: str, registry: Registry) -> Iterator[TestClient]:
    """The service on SQLite and on PostgreSQL with named API keys; requests without `X-Test-Actor` use the
    `tester` admin key, the others the named one (the header is turned into that name's key)."""
    entries = ",".join(f"{n}:{scope}:{digest(_key(n))}" for n, scope in KEYS.items())
    c = make_client(database_url, registry, api_keys=entries)

    original = c.request

    def request(method: str, url: httpx.URL | str, **kwargs: Any) -> httpx.Response:
        headers = dict(kwargs.pop("headers", None) or {})
        name = headers.pop("X-Test-Actor", "tester")
        headers["X-API-Key"] = _key(name)
        return original(method, url, headers=headers, **kwargs)

    c.request = request  # type: ignore[method-assign]
    with c:
        yield c


def _calibrate(client: TestClient, robot_id: str, seed: int, **extra: object) -> dict[str, Any]:
    sim = perturbed_robot(DESC, seed=seed)
    body = {"measurements": records(DESC, sim, sample_workspace(DESC, 40, seed=seed + 1), seed=seed + 2), **extra}
    answer = client.post(f"/v1/robots/{robot_id}/calibrations", json=body, headers={"X-Test-Actor": "metrology"})
    assert answer.status_code == 201, answer.text
    return dict(answer.json())


def _values(client: TestClient, robot_id: str, version: int | None = None) -> list[float]:
    query = "" if version is None else f"?version={version}"
    return [p["value"] for p in client.get(f"/v1/robots/{robot_id}/parameters{query}").json()["parameters"]]


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_versions_restore_and_diff(client: TestClient, robot_id: str) -> None:
    first = _calibrate(client, robot_id, 51, notes="after the crash", instrument={"name": "AT960", "serial": "X1"})
    assert first["user_notes"] == "after the crash" and first["instrument"] == {"name": "AT960", "serial": "X1"}
    second = _calibrate(client, robot_id, 61)
    assert (first["parameter_version"], second["parameter_version"]) == (2, 3)

    listed = client.get(f"/v1/robots/{robot_id}/parameter-versions")
    rows = listed.json()
    assert [(r["version"], r["provenance"], r["current"]) for r in rows] == [
        (1, "nominal", False),
        (2, "calibration", False),
        (3, "calibration", True),
    ]
    assert rows[1]["calibration_id"] == first["id"] and rows[1]["actor"] == "metrology"
    etag = listed.headers["etag"]
    assert etag == client.get(f"/v1/robots/{robot_id}").headers["etag"]

    # Restore 2 with a stale ETag: refused, nothing stored.
    stale = client.post(f"/v1/robots/{robot_id}/parameter-versions/2/restore", headers={"If-Match": '"1"'})
    assert stale.status_code == 412 and stale.json()["current"] == etag
    assert len(client.get(f"/v1/robots/{robot_id}/parameter-versions").json()) == 3
    restored = client.post(
        f"/v1/robots/{robot_id}/parameter-versions/2/restore", headers={"If-Match": etag, "X-Test-Actor": "ops"}
    )
    assert restored.status_code == 201, restored.text
    assert restored.json() | {"created_at": None} == {
        "version": 4,
        "provenance": "restore",
        "calibration_id": None,
        "restored_from": 2,
        "created_at": None,
        "actor": "ops",
        "current": True,
        # the same values, calibrated under the same conditions as version 2
        "conditions": next(
            v["conditions"] for v in client.get(f"/v1/robots/{robot_id}/parameter-versions").json() if v["version"] == 2
        ),
    }
    assert restored.json()["conditions"] is not None
    assert restored.headers["etag"] != etag
    assert _values(client, robot_id) == _values(client, robot_id, 2)  # equal to version 2, to the last digit
    assert _values(client, robot_id, 3) == [p["value"] for p in second["parameters"]]  # 3 untouched
    missing = client.post(f"/v1/robots/{robot_id}/parameter-versions/9/restore")
    assert missing.status_code == 422 and missing.json()["field"] == "version"

    # Diff 2 → 3, checked by hand on every parameter from the two documents.
    diff = client.get(f"/v1/robots/{robot_id}/parameter-versions/2/diff/3").json()
    a = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters?version=2").json()["parameters"]}
    b = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters?version=3").json()["parameters"]}
    sigmas, geometry = [], []
    for row in diff["parameters"]:
        pa, pb = a[row["name"]], b[row["name"]]
        assert row["registration"] == row["name"].startswith("base.")  # where the tracker stood
        assert (row["a"], row["b"]) == (pa["value"], pb["value"])
        assert row["difference"] == pytest.approx(pb["value"] - pa["value"], abs=1e-12)
        known = [s for s in (pa["std_error"], pb["std_error"]) if s is not None]
        if known:
            combined = math.sqrt(sum(s * s for s in known))
            assert row["std_error"] == pytest.approx(combined, rel=1e-12)
            assert row["difference_sigma"] == pytest.approx(row["difference"] / combined, rel=1e-9)
            sigmas.append(abs(row["difference_sigma"]))
            if not row["registration"]:
                geometry.append(abs(row["difference_sigma"]))
        else:
            assert row["std_error"] is None and row["difference_sigma"] is None
    assert diff["max_abs_sigma"] == pytest.approx(max(sigmas))
    assert diff["geometry_max_abs_sigma"] == pytest.approx(max(geometry))
    # Two calibrations of two different (simulated) robots differ by many σ on the geometry they both estimate.
    assert diff["max_abs_sigma"] > 10
    same = client.get(f"/v1/robots/{robot_id}/parameter-versions/2/diff/4").json()
    assert same["changed"] == [] and same["max_abs_sigma"] == 0.0


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_patch_etag_delete_and_the_audit_trail(client: TestClient) -> None:
    created = client.post("/v1/robots", json={"name": "cell-7"}, headers={"X-Test-Actor": "alice"})
    robot_id, etag = created.json()["id"], created.headers["etag"]
    patched = client.patch(
        f"/v1/robots/{robot_id}",
        json={
            "name": "cell-7b",
            "notes": "moved to bay 2",
            "tool": {"position": [0, 0, 120], "orientation": [1, 0, 0, 0]},
        },
        headers={"If-Match": etag, "X-Test-Actor": "alice"},
    )
    assert patched.status_code == 200, patched.text
    robot = patched.json()
    assert (robot["name"], robot["notes"], robot["parameter_version"]) == ("cell-7b", "moved to bay 2", 2)
    assert robot["tool"]["position"] == [0.0, 0.0, 120.0] and patched.headers["etag"] != etag
    # The new tool guess is the new version's tool; FK moves by exactly 120 mm along the platform's z.
    params = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]}
    assert params["tool.z"]["value"] == 120.0 and params["tool.z"]["nominal"] == 120.0
    joints = sample_workspace(DESC, 3, seed=5)
    fk = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": (joints * DESC.joint_to_boundary).tolist()}
    ).json()
    fk_nominal = forward_kinematics(DESC, joints, DESC.parameters.nominal)
    expected = fk_nominal.positions + 120.0 * fk_nominal.rotations[:, :, 2]
    assert np.allclose([p["position"] for p in fk["poses"]], expected, atol=1e-9)

    assert client.patch(f"/v1/robots/{robot_id}", json={"name": "x"}, headers={"If-Match": etag}).status_code == 412
    bad = client.patch(f"/v1/robots/{robot_id}", json={"name": ""})
    assert bad.status_code == 422 and bad.json()["errors"][0]["loc"][-1] == "name"
    assert client.get(f"/v1/robots/{robot_id}").json()["name"] == "cell-7b"  # nothing half-written
    assert client.delete(f"/v1/robots/{robot_id}", headers={"If-Match": etag}).status_code == 412
    current = client.get(f"/v1/robots/{robot_id}").headers["etag"]
    assert (
        client.delete(f"/v1/robots/{robot_id}", headers={"If-Match": current, "X-Test-Actor": "bob"}).status_code == 204
    )

    trail = client.get("/v1/audit", params={"robot_id": robot_id}).json()
    assert [(e["action"], e["actor"], e["version"]) for e in trail] == [
        ("robot.created", "alice", 1),
        ("version.edited", "alice", 2),
        ("robot.updated", "alice", 2),
        ("robot.deleted", "bob", 2),
    ]
    assert trail[2]["details"] == {"changed": ["name", "notes", "tool"]}
    assert all(e["request_id"] for e in trail) and trail[0]["request_id"] != trail[1]["request_id"]
    assert trail[1]["request_id"] == trail[2]["request_id"]  # one request, two events
    deleted_at = trail[3]["at"]
    assert [e["action"] for e in client.get("/v1/audit", params={"action": "robot.deleted"}).json()] == [
        "robot.deleted"
    ]
    assert [e["action"] for e in client.get("/v1/audit", params={"since": deleted_at}).json()] == ["robot.deleted"]
    assert len(client.get("/v1/audit", params={"until": deleted_at, "robot_id": robot_id}).json()) == 3
    assert len(client.get("/v1/audit", params={"limit": 2, "offset": 1}).json()) == 2
    naive = client.get("/v1/audit", params={"since": "2026-01-01T00:00:00"})
    assert naive.status_code == 422 and naive.json()["field"] == "since"
    assert client.get("/v1/audit", params={"action": "robot.exploded"}).status_code == 422


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_calibrations_and_restores_are_in_the_trail(client: TestClient, robot_id: str) -> None:
    calibration = _calibrate(client, robot_id, 71)
    client.post(f"/v1/robots/{robot_id}/parameter-versions/1/restore", headers={"X-Test-Actor": "ops"})
    trail = client.get("/v1/audit", params={"robot_id": robot_id}).json()
    assert [(e["action"], e["actor"], e["version"]) for e in trail][1:] == [
        ("version.calibrated", "metrology", 2),
        ("version.restored", "ops", 3),
    ]
    assert trail[1]["details"] == {"from_version": 1, "calibration_id": calibration["id"]}
    assert trail[2]["details"] == {"from_version": 2, "restored_from": 1}


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_campaign_behind_a_calibration(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=81)
    recs = records(DESC, sim, sample_workspace(DESC, 30, seed=82), seed=83)
    # Not applied, so the second fit below starts from the same (nominal) version.
    calibration = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs, "apply": False}).json()
    url = f"/v1/campaigns/{calibration['campaign_id']}"
    stored = client.get(url).json()
    assert stored["robot_id"] == robot_id
    assert [{k: r[k] for k in ("joints", "position", "orientation")} for r in stored["measurements"]] == recs
    as_csv = client.get(url, headers={"Accept": "text/csv"})
    assert as_csv.headers["content-type"].startswith("text/csv")
    assert client.get(url + "?format=csv").text == as_csv.text
    # The CSV is the spec's campaign file: fitting it again gives the same calibration.
    again = client.post(
        f"/v1/robots/{robot_id}/calibrations?apply=false",
        content=as_csv.text,
        headers={"Content-Type": "text/csv"},
    ).json()
    assert again["parameters"] == calibration["parameters"]
    assert client.get(url, headers={"Accept": "image/png"}).status_code == 406
    assert client.get("/v1/campaigns/nope").status_code == 404


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_an_async_calibration_is_audited_under_its_submitter(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=77)
    body = {"measurements": records(DESC, sim, sample_workspace(DESC, 40, seed=78), seed=79)}
    job = client.post(
        f"/v1/robots/{robot_id}/calibrations?async=true", json=body, headers={"X-Test-Actor": "metrology"}
    ).json()
    state = finished_job(client, f"/v1/jobs/{job['job_id']}")
    assert state["status"] == "succeeded", state
    trail = client.get("/v1/audit", params={"robot_id": robot_id, "action": "version.calibrated"}).json()
    assert [e["actor"] for e in trail] == ["metrology"] and trail[0]["request_id"]
