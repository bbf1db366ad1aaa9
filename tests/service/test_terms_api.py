"""Temperature and load over the API: records with temperature_c and a payload, options.terms, the terms'
parameters in ppm/K and µm/N, FK and IK at a temperature, CSV with a temperature column, and 422s naming the
field. The truth is a simulated IWR with κ = 20 ppm/K (models.simulation); every number is checked against the
models directly."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.description.examples import ur5_like_document
from models.description.terms import ModelTerms, make_conditions
from models.simulation import SimulatedRobot, measure, perturbed_robot
from models.transforms import matrix_to_quaternion

GEOMETRY = iwr()
THERMAL = GEOMETRY.with_terms(ModelTerms(thermal=True))
N = 60


def _campaign(seed: int = 3) -> tuple[SimulatedRobot, list[dict[str, object]], np.ndarray]:
    sim = perturbed_robot(THERMAL, seed=seed)
    truth = THERMAL.parameters.with_values(sim.truth, {"thermal.legs": 20e-6, "thermal.axes": 20e-6})
    sim = SimulatedRobot(THERMAL, sim.nominal, truth)
    joints = sample_workspace(GEOMETRY, N, seed=31)
    temps = np.random.default_rng(5).uniform(16.0, 28.0, N)
    campaign = measure(sim, joints, seed=32, conditions=make_conditions(N, temps))
    assert campaign.quaternions is not None
    recs = [
        {
            "joints": (campaign.joints[k] * GEOMETRY.joint_to_boundary).tolist(),
            "position": campaign.positions[k].tolist(),
            "orientation": campaign.quaternions[k].tolist(),
            "temperature_c": float(temps[k]),
        }
        for k in range(N)
    ]
    return sim, recs, temps


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_thermal_calibration_then_fk_and_ik_at_a_temperature(client: TestClient, robot_id: str) -> None:
    _, recs, _ = _campaign()
    url = f"/v1/robots/{robot_id}/calibrations"
    r = client.post(url, json={"measurements": recs, "options": {"terms": ["thermal"]}})
    assert r.status_code == 201, r.text
    body = r.json()
    assert body["status"] == "succeeded" and body["applied"], body.get("not_applied_reason")
    assert {"thermal.legs", "thermal.axes"} <= set(body["identifiable"])
    report = client.get(f"/v1/calibrations/{body['id']}/report", headers={"accept": "text/html"})
    assert report.status_code == 200 and "thermal.legs" in report.text and "ppm/K" in report.text
    params = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]}
    assert len(params) == THERMAL.n_params
    kappa = params["thermal.legs"]
    assert kappa["unit"] == "ppm/K" and kappa["nominal"] == 11.7
    assert abs(kappa["value"] - 20.0) <= 3 * kappa["std_error"] and kappa["std_error"] < 5

    # FK at 26 °C equals the models' FK of the stored version at 26 °C
    theta = THERMAL.parameters.from_boundary([params[n]["value"] for n in THERMAL.parameters.names])
    joints = sample_workspace(GEOMETRY, 4, seed=9)
    fk = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics",
        json={"joints": (joints * GEOMETRY.joint_to_boundary).tolist(), "temperature_c": 26.0},
    )
    assert fk.status_code == 200, fk.text
    expected = forward_kinematics(THERMAL, joints, theta, conditions=make_conditions(4, 26.0)).positions
    got = np.array([p["position"] for p in fk.json()["poses"]])
    assert np.abs(got - expected).max() < 1e-6
    at_ref = forward_kinematics(THERMAL, joints, theta, conditions=make_conditions(4, 20.0)).positions
    assert np.abs(got - at_ref).max() > 0.005  # 6 K of expansion moves the TCP by micrometres

    # IK at one temperature per target: the commands reach the targets at those temperatures
    temps = [17.0, 21.0, 25.0, 27.5]
    targets = forward_kinematics(THERMAL, joints, theta, conditions=make_conditions(4, temps))
    quats = matrix_to_quaternion(targets.rotations)
    ik = client.post(
        f"/v1/robots/{robot_id}/inverse-kinematics",
        json={
            "targets": [
                {"position": p.tolist(), "orientation": q.tolist()}
                for p, q in zip(targets.positions, quats, strict=True)
            ],
            "temperature_c": temps,
        },
    )
    assert ik.status_code == 200, ik.text
    commands = np.array(ik.json()["joints"]) / GEOMETRY.joint_to_boundary
    reached = forward_kinematics(THERMAL, commands, theta, conditions=make_conditions(4, temps), check_ranges=False)
    assert np.linalg.norm(reached.positions - targets.positions, axis=1).max() < 1e-6
    r = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics",
        json={"joints": (joints * GEOMETRY.joint_to_boundary).tolist(), "temperature_c": [20.0, 21.0]},
    )
    assert r.status_code == 422 and r.json()["field"] == "temperature_c"

    # the nominal (geometric) version against the thermal one: κ differs from its nominal 11.7 ppm/K
    diff = client.get(f"/v1/robots/{robot_id}/parameter-versions/1/diff/2")
    assert diff.status_code == 200, diff.text
    rows = {p["name"]: p for p in diff.json()["parameters"]}
    assert rows["thermal.legs"]["a"] == 11.7 and rows["thermal.legs"]["b"] == kappa["value"]
    # the export (CSV) re-imports as a version with the terms' values
    export = client.get(f"/v1/robots/{robot_id}/parameters", params={"format": "csv"})
    assert export.status_code == 200 and "ppm/K" in export.text
    again = client.post(
        f"/v1/robots/{robot_id}/parameter-versions", content=export.text, headers={"content-type": "text/csv"}
    )
    assert again.status_code == 201, again.text
    params3 = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]}
    assert params3["thermal.legs"]["value"] == kappa["value"]


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_geometric_calibration_of_thermal_data_names_the_missing_term(client: TestClient, robot_id: str) -> None:
    _, recs, _ = _campaign()
    r = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs, "apply": False})
    assert r.status_code == 201, r.text
    body = r.json()
    assert not body["noise_consistent"]
    findings = [d["finding"] for d in body["diagnoses"]]
    assert findings == ["temperature_term"]
    assert any("temperature term may be missing" in n for n in body["notes"])


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_csv_keeps_the_temperature_column(client: TestClient, robot_id: str) -> None:
    _, recs, _ = _campaign()
    lines = ["q1,q2,q3,q4,l1,l2,l3,l4,l5,l6,x,y,z,qw,qx,qy,qz,temperature_c"]
    lines += [
        ",".join(repr(float(v)) for v in [*r["joints"], *r["position"], *r["orientation"], r["temperature_c"]])  # type: ignore[misc]
        for r in recs
    ]
    r = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        content="\n".join(lines),
        params={"terms": "thermal"},
        headers={"content-type": "text/csv"},
    )
    assert r.status_code == 201, r.text
    assert "thermal.legs" in r.json()["identifiable"]


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_bad_term_requests_are_422_naming_the_field(client: TestClient, robot_id: str) -> None:
    _, recs, _ = _campaign()
    url = f"/v1/robots/{robot_id}/calibrations"
    no_temp = [dict(r) for r in recs]
    del no_temp[4]["temperature_c"]
    r = client.post(url, json={"measurements": no_temp, "options": {"terms": ["thermal"]}})
    assert r.status_code == 422 and r.json()["field"] == "measurements[4].temperature_c"
    r = client.post(url, json={"measurements": recs, "options": {"terms": ["compliance"]}})
    assert r.status_code == 422 and r.json()["field"] == "payload"
    arm = client.post("/v1/robots", json={"name": "arm", "structure": ur5_like_document()}).json()
    arm_recs = [{"joints": [0, 0, 0, 0, 0, 0], "position": [0, 0, 0], "temperature_c": 20.0}] * 10
    r = client.post(
        f"/v1/robots/{arm['id']}/calibrations", json={"measurements": arm_recs, "options": {"terms": ["thermal"]}}
    )
    assert r.status_code == 422 and r.json()["field"] == "options.terms"
    assert "prismatic" in r.json()["detail"]
    r = client.post(url, json={"measurements": recs, "options": {"terms": ["humidity"]}})
    assert r.status_code == 422


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_pose_design_for_the_thermal_term_spreads_the_temperatures(client: TestClient, robot_id: str) -> None:
    url = f"/v1/robots/{robot_id}/pose-designs"
    body = {"count": 30, "candidate_count": 200, "terms": ["thermal"], "temperature_levels_c": [16, 22, 28]}
    r = client.post(url, json=body)
    assert r.status_code == 201, r.text
    design = r.json()
    assert {"thermal.legs", "thermal.axes"} <= set(design["identifiable"])
    temps = design["temperature_c"]
    assert len(temps) == 30 and set(temps) <= {16.0, 22.0, 28.0} and min(temps) == 16.0 and max(temps) == 28.0
    r = client.post(url, json={"count": 30, "temperature_levels_c": [16, 28]})
    assert r.status_code == 422 and r.json()["field"] == "temperature_levels_c"
