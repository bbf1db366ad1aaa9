"""Validations against hand-computed values on a small campaign, and on a simulated robot whose truth is known."""

from __future__ import annotations

import math

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.noise import NoiseModel
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion, rotvec_to_matrix_np
from tests.service.helpers import records

DESC = iwr()


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_hand_computed_small_campaign(client: TestClient, robot_id: str) -> None:
    """Two commands, three cycles each, measured at the nominal TCP plus offsets chosen by hand."""
    joints = sample_workspace(DESC, 2, seed=3)
    fk = forward_kinematics(DESC, joints, DESC.parameters.nominal)
    offsets_a = np.array([[0.1, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, -0.3]])
    offsets_b = np.array([[0.05, 0.0, 0.0], [0.0, -0.05, 0.0], [0.0, 0.0, 0.05]])
    tilt = rotvec_to_matrix_np(np.array([0.0, 0.0, math.radians(0.02)]))  # 0.02° about z on the first record
    recs = []
    for k, (pose, offsets) in enumerate(((0, offsets_a), (1, offsets_b))):
        for i, offset in enumerate(offsets):
            rotation = fk.rotations[pose] @ (tilt if (k, i) == (0, 0) else np.eye(3))
            recs.append(
                {
                    "joints": (joints[pose] * DESC.joint_to_boundary).tolist(),
                    "position": (fk.positions[pose] + offset).tolist(),
                    "orientation": matrix_to_quaternion(rotation).tolist(),
                }
            )
    answer = client.post(
        f"/v1/robots/{robot_id}/validations",
        json={"measurements": recs, "notes": "bay 2", "instrument": {"name": "AT960", "serial": "123"}},
    )
    assert answer.status_code == 201, answer.text
    body = answer.json()
    assert (body["notes"], body["instrument"], body["measurements"]) == ("bay 2", {"name": "AT960", "serial": "123"}, 6)
    (result,) = body["results"]
    assert result["version"] == 1 and not result["registered"]
    per_pose = [0.1, 0.2, 0.3, 0.05, 0.05, 0.05]
    assert [p["position_mm"] for p in result["per_pose"]] == pytest.approx(per_pose, abs=1e-9)
    assert [p["orientation_deg"] for p in result["per_pose"]] == pytest.approx([0.02, 0, 0, 0, 0, 0], abs=1e-7)
    rms = math.sqrt((0.01 + 0.04 + 0.09 + 3 * 0.0025) / 6)  # = 0.15684...
    assert result["position_mm"]["rms"] == pytest.approx(rms, abs=1e-9)
    assert result["position_mm"]["max"] == pytest.approx(0.3, abs=1e-9)
    assert result["position_mm"]["percentiles"]["p50"] == pytest.approx(0.075, abs=1e-9)  # mean of 0.05 and 0.1
    assert result["orientation_deg"]["max"] == pytest.approx(0.02, abs=1e-7)

    a, b = result["iso9283"]["poses"]
    assert (a["cycles"], a["records"], b["records"]) == (3, [0, 1, 2], [3, 4, 5])
    # AP: the barycentre offset (0.1, 0.2, −0.3)/3.
    assert a["AP_mm"] == pytest.approx(math.sqrt(0.1**2 + 0.2**2 + 0.3**2) / 3, abs=1e-9)
    assert a["AP_xyz_mm"] == pytest.approx([0.1 / 3, 0.2 / 3, -0.1], abs=1e-9)
    # RP: distances l_j of the three cycles from the barycentre, l̄ + 3 S_l (sample standard deviation).
    bary = offsets_a.mean(axis=0)
    lengths = [math.dist(o, bary) for o in offsets_a]
    mean = sum(lengths) / 3
    s_l = math.sqrt(sum((x - mean) ** 2 for x in lengths) / 2)
    assert a["RP_mm"] == pytest.approx(mean + 3 * s_l, abs=1e-9)
    # B: barycentre offset (0.05, −0.05, 0.05)/3.
    assert b["AP_mm"] == pytest.approx(0.05 * math.sqrt(3) / 3, abs=1e-9)
    # Distance accuracy between A and B, cycle by cycle.
    (distance,) = result["iso9283"]["distances"]
    commanded = math.dist(fk.positions[0], fk.positions[1])
    attained = [
        math.dist(fk.positions[0] + oa, fk.positions[1] + ob) for oa, ob in zip(offsets_a, offsets_b, strict=True)
    ]
    assert distance["commanded_mm"] == pytest.approx(commanded, abs=1e-9)
    assert distance["AD_mm"] == pytest.approx(sum(attained) / 3 - commanded, abs=1e-9)

    assert client.get(f"/v1/validations/{body['id']}").json() == body
    assert client.get(f"/v1/robots/{robot_id}/validations").json() == [body]
    stored = client.get(f"/v1/campaigns/{body['campaign_id']}").json()["measurements"]
    assert [r["position"] for r in stored] == [r["position"] for r in recs]


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_bad_validations_are_refused_and_store_nothing(client: TestClient, robot_id: str) -> None:
    joints = (sample_workspace(DESC, 3, seed=4) * DESC.joint_to_boundary).tolist()
    recs = [{"joints": q, "position": [0.0, 0.0, 0.0]} for q in joints]
    missing = client.post(f"/v1/robots/{robot_id}/validations", json={"measurements": recs, "versions": [1, 7]})
    assert missing.status_code == 422 and missing.json()["field"] == "versions[1]"
    out_of_range = [{**recs[0], "joints": [1e5, *joints[0][1:]]}]
    assert client.post(f"/v1/robots/{robot_id}/validations", json={"measurements": out_of_range}).status_code == 422
    mixed = [recs[0], {**recs[1], "orientation": [1, 0, 0, 0]}]
    assert client.post(f"/v1/robots/{robot_id}/validations", json={"measurements": mixed}).status_code == 400
    assert client.post("/v1/robots/nope/validations", json={"measurements": recs}).status_code == 404
    assert client.get(f"/v1/robots/{robot_id}/validations").json() == []
    assert client.get("/v1/validations/nope").status_code == 404
    bad_version = client.post(f"/v1/robots/{robot_id}/iso9283-poses", json={"version": 3})
    assert bad_version.status_code == 422 and bad_version.json()["field"] == "version"
    assert client.post(f"/v1/robots/{robot_id}/iso9283-poses", json={"seed": -1}).status_code == 422


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_iso_cube_on_a_simulated_robot_with_known_truth(client: TestClient, robot_id: str) -> None:
    """Calibrate, ask for the ISO cube from the calibrated version, measure it in 30 cycles on the true robot:
    AP of each pose is the true model error there, within the noise of 30 cycles, for both versions."""
    sim = perturbed_robot(DESC, seed=91)
    fit = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        json={"measurements": records(DESC, sim, sample_workspace(DESC, 60, seed=92), seed=93)},
    ).json()
    assert fit["parameter_version"] == 2
    cube = client.post(f"/v1/robots/{robot_id}/iso9283-poses", json={}).json()
    assert [c["name"] for c in cube["corners"]] == [f"C{i}" for i in range(1, 9)]
    assert [p["name"] for p in cube["poses"]] == [f"P{i}" for i in range(1, 6)] and cube["version"] == 2
    commands = np.array([p["joints"] for p in cube["poses"]]) / DESC.joint_to_boundary
    table = DESC.parameters
    calibrated = table.from_boundary(
        [p["value"] for p in client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]]
    )
    np.testing.assert_allclose(
        forward_kinematics(DESC, commands, calibrated).positions, [p["position"] for p in cube["poses"]], atol=1e-6
    )
    sigma, cycles = 0.025, 30
    campaign = measure(sim, np.tile(commands, (cycles, 1)), NoiseModel(sigma, math.radians(0.005)), seed=94)
    recs = [
        {
            "joints": (campaign.joints[k] * DESC.joint_to_boundary).tolist(),
            "position": campaign.positions[k].tolist(),
            "orientation": campaign.quaternions[k].tolist(),  # type: ignore[index]
        }
        for k in range(campaign.size)
    ]
    body = client.post(f"/v1/robots/{robot_id}/validations", json={"measurements": recs, "versions": [2]}).json()
    (result,) = body["results"]
    truth = forward_kinematics(DESC, commands, sim.truth).positions
    model = forward_kinematics(DESC, commands, calibrated).positions
    expected = np.linalg.norm(truth - model, axis=1)
    got = np.array([p["AP_mm"] for p in result["iso9283"]["poses"]])
    np.testing.assert_allclose(got, expected, atol=4 * sigma / math.sqrt(cycles))
    assert all(p["cycles"] == cycles for p in result["iso9283"]["poses"])
    assert len(result["iso9283"]["distances"]) == 4
    # Repeatability is the instrument's noise alone: E|e| + 3 sd|e| of a 3-D Gaussian (see test_accuracy).
    expected_rp = sigma * (2 * math.sqrt(2 / math.pi) + 3 * math.sqrt(3 - 8 / math.pi))
    assert [p["RP_mm"] for p in result["iso9283"]["poses"]] == pytest.approx([expected_rp] * 5, rel=0.35)
    # The calibrated version leaves little more than the noise (RMS of |e| is σ√3 = 0.043 mm).
    assert result["position_mm"]["rms"] < 1.5 * sigma * math.sqrt(3)
    nominal = client.post(
        f"/v1/robots/{robot_id}/validations", json={"measurements": recs, "versions": [1], "register": True}
    ).json()["results"][0]
    # Registered on the five points of one cube, the rigid fit absorbs most of the nominal geometry's error
    # (see tests/models/test_accuracy.py); what is left still stands well above the calibrated version's.
    assert nominal["registered"] and nominal["position_mm"]["rms"] > 1.5 * result["position_mm"]["rms"]


def test_a_robot_with_validations_can_be_deleted(client: TestClient, robot_id: str) -> None:
    joints = (sample_workspace(DESC, 3, seed=6) * DESC.joint_to_boundary).tolist()
    recs = [{"joints": q, "position": [1.0, 2.0, 3.0]} for q in joints]
    made = client.post(f"/v1/robots/{robot_id}/validations", json={"measurements": recs}).json()
    assert "orientation_deg" not in made["results"][0] and "iso9283" not in made["results"][0]  # position-only
    assert client.delete(f"/v1/robots/{robot_id}").status_code == 204
    assert client.get(f"/v1/validations/{made['id']}").status_code == 404
    assert client.get(f"/v1/campaigns/{made['campaign_id']}").status_code == 404
    assert [e["action"] for e in client.get("/v1/audit", params={"robot_id": robot_id}).json()] == [
        "robot.created",
        "robot.deleted",
    ]
