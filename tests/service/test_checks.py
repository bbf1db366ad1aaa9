"""Quick checks over HTTP on the IWR: refused before a calibration, then after one from a simulated campaign, a
designed check of the robot as it is (fine) and after a known 0.1 mm change of one leg's offset (changed, that
leg named with its size). Pose records: from 8 positions alone the IWR's leg offsets are seen from 0.10-0.15 mm
(the design's `detectable`). Bad input stores nothing; the history puts calibrations and checks on one timeline."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from harness.checks import changed
from harness.records import records
from models import forward_kinematics, iwr, sample_workspace
from models.simulation import SimulatedRobot, perturbed_robot

DESC = iwr()
LEG = DESC.parameters.index["leg3.offset"]


def _tracker(sim: SimulatedRobot, joints_deg: list[list[float]], seed: int) -> list[dict[str, object]]:
    """Poses (position and orientation), as the version was calibrated from."""
    joints = np.array(joints_deg) / DESC.joint_to_boundary
    return records(DESC, sim, joints, seed)


def test_a_robot_never_calibrated_is_refused_or_checked_against_its_tolerances(
    client: TestClient, robot_id: str
) -> None:
    sim = perturbed_robot(DESC, seed=3)
    recs = records(DESC, sim, sample_workspace(DESC, 6, seed=4), 5, position_only=True)
    refused = client.post(f"/v1/robots/{robot_id}/checks", json={"measurements": recs})
    assert refused.status_code == 422 and "calibrate the robot first" in refused.json()["detail"]
    assert client.get(f"/v1/robots/{robot_id}/checks").json() == []
    nominal = client.post(f"/v1/robots/{robot_id}/checks", json={"measurements": recs, "against": "tolerances"})
    assert nominal.status_code == 201, nominal.text
    assert nominal.json()["against"] == "tolerances" and nominal.json()["version"] == 1


@pytest.mark.slow  # a calibration over HTTP: outside the inner loop (make test-fast)
def test_a_designed_check_before_and_after_a_change(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=21)
    campaign = records(DESC, sim, sample_workspace(DESC, 60, seed=22), 23)
    fit = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": campaign})
    assert fit.status_code == 201 and fit.json()["parameter_version"] == 2, fit.text

    design = client.post(f"/v1/robots/{robot_id}/checks/design", json={"count": 8, "seed": 1, "measurement": "pose"})
    assert design.status_code == 200, design.text
    plan = design.json()
    assert plan["version"] == 2 and len(plan["poses"]) == 8 and plan["registered"]
    watched = {w["name"]: w for w in plan["watched"]}
    assert "leg3.offset" in watched and watched["leg3.offset"]["detectable"] < 0.1  # mm: a tenth is seen
    poses = [p["joints"] for p in plan["poses"]]

    fine = client.post(f"/v1/robots/{robot_id}/checks", json={"measurements": _tracker(sim, poses, 31)})
    assert fine.status_code == 201, fine.text
    body = fine.json()
    assert body["verdict"] == "fine" and body["recommendation"]["action"] == "none"
    assert body["statistic"]["dof"] == 8 * 6 - 6 and body["statistic"]["alpha"] == 0.01
    assert body["statistic"]["chi2"] <= body["statistic"]["threshold"]

    moved = changed(sim, LEG, 0.1)
    answer = client.post(
        f"/v1/robots/{robot_id}/checks",
        json={"measurements": _tracker(moved, poses, 32), "notes": "after the leg 3 motor swap"},
    )
    assert answer.status_code == 201, answer.text
    check = answer.json()
    assert check["verdict"] == "changed", check
    explanation = check["explanation"]
    # Leg 3's length: its offset, or its platform joint along the leg (b.z), which eight poses barely tell apart.
    assert explanation["name"] in {"leg3.offset", "leg3.b.z"} and explanation["explains"]
    (change,) = explanation["parameters"]
    assert change["unit"] == "mm" and abs(abs(change["change"]) - 0.1) < 0.03
    assert check["recommendation"]["action"] == "refit"
    assert check["recommendation"]["parameters"] == [explanation["name"]]
    assert check["recommendation"]["poses"] >= 8 and "re-fit leg3" in check["recommendation"]["message"]

    assert client.get(f"/v1/checks/{check['id']}").json() == check
    assert [c["id"] for c in client.get(f"/v1/robots/{robot_id}/checks").json()] == [body["id"], check["id"]]
    history = client.get(f"/v1/robots/{robot_id}/history").json()
    assert [(e["kind"], e["outcome"]) for e in history] == [
        ("calibration", "succeeded, applied"),
        ("check", "fine"),
        ("check", "changed"),
    ]
    assert client.get(f"/v1/robots/{robot_id}/history", params={"offset": 1, "limit": 1}).json() == [history[1]]
    assert client.delete(f"/v1/robots/{robot_id}").status_code == 204
    assert client.get(f"/v1/checks/{check['id']}").status_code == 404


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_bad_checks_are_refused_and_store_nothing(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=5)
    recs = records(DESC, sim, sample_workspace(DESC, 6, seed=6), 7, position_only=True)
    against = {"against": "tolerances"}
    url = f"/v1/robots/{robot_id}/checks"
    few = client.post(url, json={"measurements": recs[:2], **against})
    assert few.status_code == 422 and "at least 3 records" in few.json()["detail"]
    short = [{**r, "joints": r["joints"][:6]} for r in recs]  # type: ignore[index]
    wrong = client.post(url, json={"measurements": short, **against})
    assert wrong.status_code == 422 and "10" in wrong.json()["detail"]
    assert client.post(url, json={"measurements": recs, "alpha": 0.7, **against}).status_code == 422
    assert client.post(url, json={"measurements": recs, "register": "maybe"}).status_code == 422
    assert client.get(url).json() == []
    assert client.get(f"/v1/robots/{robot_id}/history").json() == []
    assert client.post("/v1/robots/nope/checks", json={"measurements": recs}).status_code == 404
    assert client.get("/v1/checks/nope").status_code == 404
    design = client.post(f"{url}/design", json={"count": 2, **against})
    assert design.status_code == 422
    unknown = client.post(f"{url}/design", json={"watch": ["elbow"], **against})
    assert unknown.status_code == 422 and "elbow" in unknown.json()["detail"]


def test_a_ballbar_check_fits_its_anchor_in_place_of_the_frame(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=8)
    joints = sample_workspace(DESC, 8, seed=9)
    tcp = forward_kinematics(DESC, joints, sim.truth).positions
    pivot = tcp.mean(axis=0) + np.array([300.0, 0.0, 0.0])
    measurements = [
        {"kind": "distance", "joints": (q * DESC.joint_to_boundary).tolist(), "anchor": "a1", "distance_mm": float(d)}
        for q, d in zip(joints, np.linalg.norm(tcp - pivot, axis=1), strict=True)
    ]
    body = {"measurements": measurements, "anchors": {"a1": {}}, "against": "tolerances"}
    answer = client.post(f"/v1/robots/{robot_id}/checks", json=body)
    assert answer.status_code == 201, answer.text
    check = answer.json()
    assert check["statistic"]["dof"] == 8 - 3 and check["measurements"] == 8 and len(check["per_record"]) == 8
    undescribed = client.post(f"/v1/robots/{robot_id}/checks", json={**body, "anchors": {}})
    assert undescribed.status_code == 400 and "a1" in undescribed.json()["detail"]
    assert len(client.get(f"/v1/robots/{robot_id}/checks").json()) == 1
