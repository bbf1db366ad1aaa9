"""The HTTP contract of api.md on a real (SQLite) database, checked against the models directly."""

from __future__ import annotations

import time

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.simulation import perturbed_robot
from models.transforms import matrix_to_quaternion
from tests.service.conftest import make_client
from tests.service.helpers import finished_job, records

DESC = iwr()


def _deg(joints: np.ndarray) -> list[list[float]]:
    out: list[list[float]] = (joints * DESC.joint_to_boundary).tolist()
    return out


def test_robot_lifecycle(client: TestClient) -> None:
    created = client.post("/v1/robots", json={"name": "cell-3", "model": "iwr"}).json()
    assert created["parameter_version"] == 1 and created["model"] == "iwr"
    assert client.get(f"/v1/robots/{created['id']}").json()["name"] == "cell-3"
    assert [r["id"] for r in client.get("/v1/robots").json()] == [created["id"]]
    params = client.get(f"/v1/robots/{created['id']}/parameters").json()
    assert params["version"] == 1 and params["provenance"] == "nominal"
    by_name = {p["name"]: p for p in params["parameters"]}
    assert len(by_name) == 70
    assert by_name["link2.theta"] == {
        "name": "link2.theta",
        "value": pytest.approx(90.0),
        "unit": "deg",
        "nominal": pytest.approx(90.0),
        "std_error": None,
        "identifiable": None,
    }
    assert by_name["link1.a"]["value"] == pytest.approx(91.0)
    assert client.delete(f"/v1/robots/{created['id']}").status_code == 204
    assert client.get(f"/v1/robots/{created['id']}").status_code == 404


def test_forward_kinematics_matches_the_model(client: TestClient, robot_id: str) -> None:
    joints = sample_workspace(DESC, 25, seed=3)
    poses = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": _deg(joints)}).json()["poses"]
    fk = forward_kinematics(DESC, joints)
    np.testing.assert_allclose([p["position"] for p in poses], fk.positions, atol=1e-9)
    q = np.array([p["orientation"] for p in poses])
    expected = matrix_to_quaternion(fk.rotations)
    np.testing.assert_allclose(np.abs(np.sum(q * expected, axis=1)), 1.0, atol=1e-12)


def test_inverse_kinematics_round_trip_and_csv(client: TestClient, robot_id: str) -> None:
    fk = forward_kinematics(DESC, sample_workspace(DESC, 5, seed=4))
    targets = [
        {"position": p.tolist(), "orientation": q.tolist()}
        for p, q in zip(fk.positions, matrix_to_quaternion(fk.rotations), strict=True)
    ]
    out = client.post(f"/v1/robots/{robot_id}/inverse-kinematics", json={"targets": targets}).json()
    assert all(out["reachable"]) and max(out["position_error_mm"]) < 1e-6
    back = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": out["joints"]}).json()["poses"]
    np.testing.assert_allclose([p["position"] for p in back], fk.positions, atol=1e-6)
    csv = client.post(
        f"/v1/robots/{robot_id}/inverse-kinematics", json={"targets": targets}, headers={"Accept": "text/csv"}
    )
    assert csv.headers["content-type"].startswith("text/csv")
    lines = csv.text.strip().splitlines()
    assert lines[0] == "q1,q2,q3,q4,l1,l2,l3,l4,l5,l6" and len(lines) == 6
    np.testing.assert_allclose([float(v) for v in lines[1].split(",")], out["joints"][0])


def test_bad_input_is_a_problem_never_a_500(client: TestClient, robot_id: str) -> None:
    url = f"/v1/robots/{robot_id}/forward-kinematics"
    r = client.post(url, json={"joints": [[400, 150, 190, 45, 420, 420, 420, 420, 420, 420]]})
    assert r.status_code == 422 and r.headers["content-type"] == "application/problem+json"
    assert r.json()["type"].endswith("joint-out-of-range") and "q3" in r.json()["detail"]
    r = client.post(
        url,
        content=b'{"joints": [[NaN, 150, 90, 45, 420, 420, 420, 420, 420, 420]]}',
        headers={"content-type": "application/json"},
    )
    assert r.status_code == 422 and r.json()["errors"][0]["loc"][:2] == ["body", "joints"]
    r = client.post(url, json={"joints": [[400, 150, 90, 45, 420, 420, 420, 420, 420, 420]], "extra": 1})
    assert r.status_code == 422
    r = client.post(url, json={"joints": [[400, 150, 90, 45, 370, 550, 370, 550, 370, 550]]})
    assert r.status_code == 422 and r.json()["type"].endswith("unreachable-pose")
    assert client.post("/v1/robots/nope/forward-kinematics", json={"joints": [[0] * 10]}).status_code == 404
    assert client.get("/v1/calibrations/nope").status_code == 404
    assert client.get("/v1/jobs/nope").status_code == 404
    r = client.post("/v1/robots", json={"name": "x", "base": {"position": [0, 0, 0], "orientation": [2, 0, 0, 0]}})
    assert r.status_code == 422 and r.json()["type"].endswith("invalid-quaternion")


def test_body_limit_gives_413(tmp_path: object) -> None:
    with make_client(f"sqlite:///{tmp_path}/limit.db", max_body_bytes=1000) as c:
        rid = c.post("/v1/robots", json={"name": "a"}).json()["id"]
        r = c.post(f"/v1/robots/{rid}/forward-kinematics", json={"joints": [[400.0] * 10] * 50})
        assert r.status_code == 413 and r.json()["status"] == 413
        assert c.get(f"/v1/robots/{rid}").status_code == 200


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_api_keys(tmp_path: object) -> None:
    with make_client(f"sqlite:///{tmp_path}/keys.db", api_keys="k1,k2") as c:
        assert c.get("/healthz").status_code == 200
        r = c.get("/v1/robots")
        assert r.status_code == 401 and r.headers["content-type"] == "application/problem+json"
        assert c.get("/v1/robots", headers={"X-API-Key": "wrong"}).status_code == 401
        assert c.get("/v1/robots", headers={"X-API-Key": "k2"}).status_code == 200


def test_health_ready_metrics_and_request_id(client: TestClient) -> None:
    assert client.get("/healthz").json() == {"status": "ok"}
    assert client.get("/readyz").status_code == 200
    r = client.get("/v1/robots", headers={"X-Request-ID": "abc123"})
    assert r.headers["X-Request-ID"] == "abc123"
    text = client.get("/metrics").text
    assert 'iwr_http_requests_total{method="GET",route="/v1/robots",status="200"}' in text
    assert "iwr_jobs" in text


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_calibration_from_csv_applies_a_new_version(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=2)
    recs = records(DESC, sim, sample_workspace(DESC, 40, seed=5), seed=6)
    lines = ["q1,q2,q3,q4,l1,l2,l3,l4,l5,l6,x,y,z,qw,qx,qy,qz"]
    lines += [",".join(repr(float(v)) for v in [*r["joints"], *r["position"], *r["orientation"]]) for r in recs]  # type: ignore[misc]
    r = client.post(
        f"/v1/robots/{robot_id}/calibrations", content="\n".join(lines), headers={"content-type": "text/csv"}
    )
    assert r.status_code == 201, r.text
    body = r.json()
    assert body["status"] == "succeeded" and body["applied"] and body["parameter_version"] == 2
    assert len(body["identifiable"]) == 54 and body["residuals"]["after"]["rms_mm"] < 0.1
    assert body["solver"]["name"] == "ipopt"
    params = client.get(f"/v1/robots/{robot_id}/parameters").json()
    assert params["version"] == 2 and params["calibration_id"] == body["id"]
    std = [p["std_error"] for p in params["parameters"] if p["identifiable"]]
    assert len(std) == 54 and all(s is not None and s > 0 for s in std)
    assert client.get(f"/v1/calibrations/{body['id']}").json()["id"] == body["id"]
    assert [c["id"] for c in client.get(f"/v1/robots/{robot_id}/calibrations").json()] == [body["id"]]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_rejected_or_failed_calibrations_change_nothing(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=3)
    recs = records(DESC, sim, sample_workspace(DESC, 40, seed=7), seed=8)
    too_few = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs[:5]})
    assert too_few.status_code == 422 and "more" in too_few.json()["detail"]
    shuffled = [dict(r, joints=recs[-1 - k]["joints"]) for k, r in enumerate(recs)]
    failed = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": shuffled})
    # A failed fit is not a success anywhere: a 422 naming the cause and the stored attempt.
    assert failed.status_code == 422, failed.text
    problem = failed.json()
    assert problem["type"].endswith("calibration-failed") and "same order" in problem["detail"]
    assert [d["finding"] for d in problem["diagnoses"]] == ["mismatch"]
    attempt = client.get(f"/v1/calibrations/{problem['calibration_id']}").json()
    assert attempt["status"] == "failed" and not attempt["applied"] and attempt["solver"]["status"] == "not_run"
    assert client.get(f"/v1/robots/{robot_id}/parameters").json()["version"] == 1
    bad_csv = client.post(
        f"/v1/robots/{robot_id}/calibrations", content="a,b\n1,2", headers={"content-type": "text/csv"}
    )
    assert bad_csv.status_code == 400 and "header" in bad_csv.json()["detail"]
    # Found by schemathesis: CR-only line endings and a field over the csv module's 128 KiB limit were 500s.
    cr_only = "\r".join(["q1,q2,q3,q4,l1,l2,l3,l4,l5,l6,x,y,z", *[",".join(["400"] * 13)] * 3])
    r = client.post(f"/v1/robots/{robot_id}/calibrations", content=cr_only, headers={"content-type": "text/csv"})
    assert r.status_code == 422, r.text  # parsed (three rows), then refused: too few poses
    huge = "q1,q2,q3,q4,l1,l2,l3,l4,l5,l6,x,y,z\n" + "1," * 12 + "9" * 200_000
    r = client.post(f"/v1/robots/{robot_id}/calibrations", content=huge, headers={"content-type": "text/csv"})
    assert r.status_code == 400 and "line 2" in r.json()["detail"]
    xml = client.post(
        f"/v1/robots/{robot_id}/calibrations", content="<x/>", headers={"content-type": "application/xml"}
    )
    assert xml.status_code == 415


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_async_jobs(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=4)
    recs = records(DESC, sim, sample_workspace(DESC, 30, seed=9), seed=10)
    r = client.post(f"/v1/robots/{robot_id}/calibrations?async=true", json={"measurements": recs})
    assert r.status_code == 202
    job = finished_job(client, r.json()["status_url"])
    assert job["status"] == "succeeded", job
    assert job["result"]["parameter_version"] == 2
    d = client.post(f"/v1/robots/{robot_id}/pose-designs?async=true", json={"count": 12, "candidate_count": 100})
    assert d.status_code == 202
    job = finished_job(client, d.json()["status_url"])
    assert job["status"] == "succeeded" and len(job["result"]["poses"]) == 12


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_pose_design_json_and_csv(client: TestClient, robot_id: str) -> None:
    cands = _deg(sample_workspace(DESC, 80, seed=11))
    r = client.post(f"/v1/robots/{robot_id}/pose-designs", json={"count": 12, "criterion": "D", "candidates": cands})
    assert r.status_code == 201, r.text
    body = r.json()
    assert len(body["poses"]) == 12 and len(set(body["indices"])) == 12
    assert [cands[i] for i in body["indices"]] == body["poses"]
    for key in ("condition_number", "log_det", "min_singular_value"):
        assert key in body["metrics"] and key in body["random_baseline"]
    assert body["bound"]["certified"] and body["metrics"]["log_det"] <= body["bound"]["value"] + 1e-9
    csv = client.get(f"/v1/pose-designs/{body['id']}", headers={"Accept": "text/csv"})
    assert csv.text.splitlines()[0] == "q1,q2,q3,q4,l1,l2,l3,l4,l5,l6" and len(csv.text.splitlines()) == 13
    bad = client.post(f"/v1/robots/{robot_id}/pose-designs", json={"count": 3, "candidates": cands})
    assert bad.status_code == 422 and "at least 10" in bad.json()["detail"]


def test_error_analysis(client: TestClient) -> None:
    r = client.post("/v1/error-analysis", json={"poses": 5, "draws": 10})
    assert r.status_code == 200
    assert r.json()
    assert client.post("/v1/error-analysis", json={"poses": 0}).status_code == 422


@pytest.mark.slow  # a spawned pool process builds its own runtimes: ~10 s here
def test_jobs_in_a_worker_process(tmp_path: object) -> None:
    """The production path: a spawned worker process picks the job from the database and writes the result."""

    with make_client(f"sqlite:///{tmp_path}/pool.db", job_workers=1) as c:
        rid = c.post("/v1/robots", json={"name": "pool"}).json()["id"]
        sim = perturbed_robot(DESC, seed=41)
        recs = records(DESC, sim, sample_workspace(DESC, 25, seed=42), seed=43)
        job_url = c.post(f"/v1/robots/{rid}/calibrations?async=true", json={"measurements": recs}).json()["status_url"]
        deadline = time.monotonic() + 120
        while (job := c.get(job_url).json())["status"] in ("queued", "running") and time.monotonic() < deadline:
            time.sleep(0.2)
        assert job["status"] == "succeeded", job
        assert c.get(f"/v1/robots/{rid}/parameters").json()["version"] == 2


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_pose_design_for_a_target_accuracy(client: TestClient, robot_id: str) -> None:
    url = f"/v1/robots/{robot_id}/pose-designs"
    body = {"target": {"rms_tcp_mm": 0.03}, "candidate_count": 300, "seed": 3}
    r = client.post(url, json=body)
    assert r.status_code == 201, r.text
    design = r.json()
    assert design["criterion"] == "I" and design["count"] == len(design["poses"]) > 0
    assert design["metrics"]["predicted_rms_tcp_mm"] <= 0.03
    curve = {p["count"]: p for p in design["curve"]}
    # The answer is the smallest K: one pose fewer (when it was probed) misses the target.
    if design["count"] - 1 in curve:
        assert curve[design["count"] - 1]["rms_tcp_mm"] > 0.03
    assert all(p["random_rms_tcp_mm"] >= p["I_rms_tcp_mm"] for p in curve.values() if p["I_rms_tcp_mm"])
    unreachable = client.post(url, json={**body, "target": {"rms_tcp_mm": 1e-5}})
    assert unreachable.status_code == 422 and unreachable.json()["type"].endswith("target-unreachable")
    assert unreachable.json()["reachable_mm"] > 1e-5
    both = client.post(url, json={**body, "count": 20})
    assert both.status_code == 422 and "either count" in both.json()["detail"]


def test_a_target_the_fixed_poses_already_reach_needs_none_and_names_the_measurement(
    client: TestClient, robot_id: str
) -> None:
    fixed = (sample_workspace(DESC, 60, seed=81) * DESC.joint_to_boundary).tolist()
    body = {"target": {"rms_tcp_mm": 1.0}, "fixed": fixed, "measurement": "position", "candidate_count": 100}
    r = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body)
    assert r.status_code == 201, r.text
    design = r.json()
    assert design["count"] == 0 and design["poses"] == [] and design["measurement"] == "position"
    assert design["fixed_mm"] is not None and design["fixed_mm"] <= 1.0


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_pose_design_constraints(client: TestClient, robot_id: str) -> None:
    url = f"/v1/robots/{robot_id}/pose-designs"
    r = client.post(
        url, json={"count": 20, "candidate_count": 300, "joint_ranges": {"q1": [100, 500]}, "min_spread": 0.05}
    )
    assert r.status_code == 201, r.text
    design = r.json()
    assert all(100 <= q[0] <= 500 for q in design["poses"])
    assert design["constraints"]["excluded"] and design["constraints"]["min_spread"] == 0.05
    wrong = client.post(url, json={"count": 20, "joint_ranges": {"q9": [0, 1]}})
    assert wrong.status_code == 422 and "q9" in wrong.json()["detail"]


def test_error_analysis_with_tolerances_the_robot_cannot_be_assembled_with_is_422(client: TestClient) -> None:
    """Found by schemathesis: a 89 mm leg offset made numpy's eigenvalues fail (500) instead of a 422."""
    body = {"distribution": "sign", "draws": 1, "poses": 1, "leg_offset_mm": 89.0}
    body |= {"dh_angle_deg": 0.0, "dh_length_mm": 0.0, "joint_position_mm": 0.0}
    answer = client.post("/v1/error-analysis", json=body)
    assert answer.status_code == 422 and answer.json()["field"] == "tolerances", answer.text


@pytest.mark.serial  # a 0.5 s branch-and-bound budget kept to 0.3 s of wall time: alone on the cores
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_pose_design_with_branch_and_bound_tightens_its_certificate(client: TestClient, robot_id: str) -> None:
    body = {"count": 20, "criterion": "D", "candidate_count": 300, "seed": 3}
    plain = client.post(f"/v1/robots/{robot_id}/pose-designs", json=body).json()
    tight = client.post(f"/v1/robots/{robot_id}/pose-designs", json={**body, "bound_seconds": 0.5}).json()
    assert plain["bound"]["branch_and_bound"] is None
    branched = tight["bound"]["branch_and_bound"]
    assert branched["nodes"] >= 1 and branched["seconds"] <= 0.5 + 0.3
    assert tight["bound"]["utility"] <= branched["root_utility"] + 1e-9  # can only fall
    assert branched["root_efficiency"] == pytest.approx(plain["efficiency"], rel=1e-6)
    assert tight["efficiency"] >= plain["efficiency"] - 1e-9
    if not branched["improved_design"]:  # the design is exchange's either way; only the certificate moved
        assert tight["indices"] == plain["indices"]
    target = client.post(
        f"/v1/robots/{robot_id}/pose-designs", json={"target": {"rms_tcp_mm": 0.05}, "bound_seconds": 1}
    )
    assert target.status_code == 422 and "bound_seconds" in target.json()["detail"]
    slow = client.post(f"/v1/robots/{robot_id}/pose-designs", json={**body, "bound_seconds": 10})
    assert slow.status_code == 422 and slow.json()["type"].endswith("work-too-large")
    assert "?async=true" in slow.json()["detail"]
