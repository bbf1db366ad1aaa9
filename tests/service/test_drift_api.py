"""Drift-aware calibrations over the API (issue 32): records with times and a marked reference pose,
options.drift, the drift in the report against the simulated one, the campaign's conditions stored with the
version, and the warnings of a later check or compensation run outside them; bad input answered with a 4xx
naming what to fix, nothing stored."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from harness.drift import DriftCampaign, drift_campaign
from models import NoiseModel, forward_kinematics, iwr, sample_workspace
from models.transforms import matrix_to_quaternion
from service.campaign_io import ImportOptions
from service.campaign_io.records import campaign_records
from service.campaign_io.tabular import read_table
from service.conversions.drift import condition_warnings
from tests.service.helpers import calibrate_robot

DESC = iwr()
NOISE = NoiseModel(0.010, float(np.radians(0.002)))
START = datetime(2026, 12, 5, 8, 0, tzinfo=UTC)


def _records(sim: DriftCampaign, *, temperatures: np.ndarray | None = None) -> list[dict[str, Any]]:
    c = sim.drifted
    assert c.quaternions is not None
    out = []
    for k in range(c.size):
        rec: dict[str, Any] = {
            "joints": (c.joints[k] * DESC.joint_to_boundary).tolist(),
            "position": c.positions[k].tolist(),
            "orientation": c.quaternions[k].tolist(),
            "time": (START + timedelta(seconds=float(sim.timeline.times_s[k]))).isoformat(),
        }
        if k in sim.timeline.reference:
            rec["reference"] = True
        if temperatures is not None:
            rec["temperature_c"] = float(temperatures[k])
        out.append(rec)
    return out


def _body(records: list[dict[str, Any]], **drift: Any) -> dict[str, Any]:
    return {
        "measurements": records,
        "noise": {"position_mm": NOISE.position_mm, "orientation_deg": float(np.degrees(NOISE.orientation_rad))},
        "options": {"drift": drift},
        "payload": {"mass_kg": 12.0},
    }


def _assert_the_drift_found(drift: dict[str, Any], sim: Any) -> None:
    """The reported drift is the simulated one, within its own σ, over the campaign's hour."""
    assert drift["over"] == "seconds" and drift["span"] == [0.0, 59 * 60.0]
    assert drift["reference_records"] == sim.timeline.reference.tolist()
    truth = sim.drift_mm[-1] - sim.drift_mm[0]
    got, sigma = np.array(drift["over_campaign_mm"]), np.array(drift["over_campaign_sigma_mm"])
    assert np.all(np.abs(got - truth) < 3.5 * sigma), (got, truth, sigma)
    np.testing.assert_allclose(drift["rate_mm_per_h"], got / (59 / 60))
    assert drift["reference_scatter"]["after_mm"] < drift["reference_scatter"]["before_mm"]


@pytest.mark.slow  # a 60-record calibration fitted twice, a check and an IK: about a second
def test_a_drift_aware_calibration_then_checks_and_commands_outside_its_conditions(
    client: TestClient, robot_id: str
) -> None:
    sim = drift_campaign(DESC, 2, noise=NOISE)
    temperatures = np.linspace(20.5, 22.0, sim.drifted.size)
    body = calibrate_robot(client, robot_id, _body(_records(sim, temperatures=temperatures)))
    assert body["status"] == "succeeded" and body["applied"], body.get("not_applied_reason")
    drift = body["drift"]
    _assert_the_drift_found(drift, sim)

    # the conditions, with the version the calibration made
    conditions = body["conditions"]
    assert conditions["temperature_c"] == {"min": 20.5, "max": 22.0}
    assert conditions["payload_kg"] == {"min": 12.0, "max": 12.0}
    assert conditions["duration_s"] == 59 * 60.0 and conditions["records"] == 60
    assert conditions["time"] == [START.isoformat(), (START + timedelta(minutes=59)).isoformat()]
    report = client.get(f"/v1/calibrations/{body['id']}/report", headers={"accept": "text/html"}).text
    assert 'id="fig-accuracy-history"' not in report  # one event: nothing over time yet
    shown = dict(re.findall(r'data-key="([^"]+)" data-value="([^"]*)"', report))
    assert float(shown["drift.magnitude_mm"]) == drift["magnitude_mm"]
    assert float(shown["drift.reference_scatter.after_mm"]) == drift["reference_scatter"]["after_mm"]
    assert float(shown["conditions.temperature_c.max"]) == 22.0 and float(shown["conditions.payload_kg.min"]) == 12
    versions = client.get(f"/v1/robots/{robot_id}/parameter-versions").json()
    assert [v["conditions"] for v in versions if v["current"]] == [conditions]

    # a check at 27 °C is answered, and warned: 5 K above what the version was calibrated under
    theta = np.array(
        DESC.parameters.from_boundary(
            [p["value"] for p in client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]]
        )
    )
    joints = sample_workspace(DESC, 6, seed=77)
    fk = forward_kinematics(DESC, joints, sim.robot.truth)
    check = [
        {
            "joints": (joints[k] * DESC.joint_to_boundary).tolist(),
            "position": fk.positions[k].tolist(),
            "temperature_c": 27.0,
            "payload": {"mass_kg": 12.0},
        }
        for k in range(6)
    ]
    answer = client.post(f"/v1/robots/{robot_id}/checks", json={"measurements": check})
    assert answer.status_code == 201, answer.text
    (warning,) = answer.json()["warnings"]
    assert warning["condition"] == "temperature_c" and warning["value"] == 27.0
    assert warning["outside_by"] == pytest.approx(5.0) and warning["calibrated"] == {"min": 20.5, "max": 22.0}

    # joint commands for a payload of 30 kg: computed, and warned about the payload only
    targets = forward_kinematics(DESC, joints[:2], theta)
    quats = matrix_to_quaternion(targets.rotations)
    ik = client.post(
        f"/v1/robots/{robot_id}/inverse-kinematics",
        json={
            "targets": [
                {"position": targets.positions[k].tolist(), "orientation": quats[k].tolist()} for k in range(2)
            ],
            "temperature_c": 21.0,
            "payload": {"mass_kg": 30.0},
        },
    )
    assert ik.status_code == 200, ik.text
    assert all(ik.json()["reachable"])
    assert [(w["condition"], w["outside_by"]) for w in ik.json()["warnings"]] == [("payload_kg", 18.0)]

    # a program to run at 19 °C: compensated, and warned 1.5 K below the calibrated range
    x, y, z = targets.positions[0]
    program = client.post(
        f"/v1/robots/{robot_id}/programs/compensate",
        json={"format": "csv", "program": f"x,y,z,a,b,c\n{x},{y},{z},0,0,0\n", "temperature_c": 19.0},
    )
    assert program.status_code == 200, program.text
    assert [(w["condition"], w["value"], w["outside_by"]) for w in program.json()["warnings"]] == [
        ("temperature_c", 19.0, 1.5)
    ]

    # the timeline: the calibration (its residual, predicted accuracy and drift), then the check
    calibration, checked = client.get(f"/v1/robots/{robot_id}/history").json()
    assert calibration["rms_mm"] == body["residuals"]["after"]["rms_mm"]
    assert calibration["predicted_mm"] == body["predicted_accuracy"]["rms_position_mm"]
    assert calibration["drift_mm"] == drift["magnitude_mm"]
    assert checked["kind"] == "check" and checked["rms_mm"] > 0
    # ... and the calibration's report draws it (two events now), this calibration ringed
    report = client.get(f"/v1/calibrations/{body['id']}/report", headers={"accept": "text/html"}).text
    assert 'id="fig-accuracy-history"' in report


def _refused(client: TestClient, robot_id: str, body: dict[str, Any], status: int, words: str) -> dict[str, Any]:
    r = client.post(f"/v1/robots/{robot_id}/calibrations", json=body)
    assert r.status_code == status, r.text
    assert words in r.json()["detail"], r.json()["detail"]
    assert client.get(f"/v1/robots/{robot_id}/calibrations").json() == []  # nothing stored
    return dict(r.json())


@pytest.fixture(scope="module")
def small() -> DriftCampaign:
    return drift_campaign(DESC, 0, noise=NOISE, records=24, every=4)


def test_a_reference_that_is_never_repeated_is_a_422(client: TestClient, robot_id: str, small: DriftCampaign) -> None:
    records = _records(small)
    for rec in records:
        rec.pop("reference", None)
    records[5]["reference"] = True
    problem = _refused(client, robot_id, _body(records), 422, "the reference pose is measured 1 time(s)")
    assert problem["field"] == "reference"


def test_marked_records_of_different_poses_are_a_422(client: TestClient, robot_id: str, small: DriftCampaign) -> None:
    records = _records(small)
    records[3]["reference"] = True  # not the reference pose
    _refused(client, robot_id, _body(records), 422, "are both marked reference but are not the same pose")


def test_no_repeated_pose_at_all_is_a_422(client: TestClient, robot_id: str, small: DriftCampaign) -> None:
    records = [r for k, r in enumerate(_records(small)) if k not in small.timeline.reference[1:]]
    for rec in records:
        rec.pop("reference", None)
    _refused(client, robot_id, _body(records), 422, "no pose of the campaign is measured twice")


def test_times_on_some_records_only_or_of_two_kinds_are_a_400(
    client: TestClient, robot_id: str, small: DriftCampaign
) -> None:
    records = _records(small)
    del records[7]["time"]
    _refused(client, robot_id, _body(records), 400, "record 7: it has no time while other records have one")
    records = _records(small)
    records[2]["time"] = 120.0
    _refused(client, robot_id, _body(records), 400, "times mix seconds and ISO 8601 times")


def test_a_time_that_is_not_a_time_and_a_degree_too_high_are_422(
    client: TestClient, robot_id: str, small: DriftCampaign
) -> None:
    records = _records(small)
    records[1]["time"] = "yesterday"
    r = client.post(f"/v1/robots/{robot_id}/calibrations", json=_body(records))
    assert r.status_code == 422 and "not an ISO 8601 time" in r.text
    r = client.post(f"/v1/robots/{robot_id}/calibrations", json=_body(_records(small), degree=4))
    assert r.status_code == 422 and "degree" in r.text


def test_the_temperature_driver_without_temperatures_is_a_422(
    client: TestClient, robot_id: str, small: DriftCampaign
) -> None:
    _refused(client, robot_id, _body(_records(small), driver="temperature"), 422, "needs every record's temperature_c")


def test_drift_with_records_of_another_kind_is_a_400(client: TestClient, robot_id: str) -> None:
    joints = sample_workspace(DESC, 3, seed=1) * DESC.joint_to_boundary
    records = [{"kind": "distance", "joints": q.tolist(), "anchor": "a1", "distance_mm": 500.0} for q in joints]
    body = {"measurements": records, "anchors": {"a1": {}}, "options": {"drift": {}}}
    _refused(client, robot_id, body, 400, "options.drift needs tracker records")


def test_warnings_name_the_condition_and_how_far_outside() -> None:
    calibrated = {"temperature_c": {"min": 18.0, "max": 22.0}, "payload_kg": {"min": 0.0, "max": 10.0}}
    inside = condition_warnings(calibrated, version=3, temperatures=[18.0, 22.0], payloads_kg=[10.0])
    assert inside == []
    (cold,) = condition_warnings(calibrated, version=3, temperatures=[15.5, 23.0], payloads_kg=[])
    assert (cold.condition, cold.value, cold.outside_by, cold.version) == ("temperature_c", 15.5, 2.5, 3)
    assert "temperature 15.5 °C is 2.5 °C outside the 18–22 °C version 3 was calibrated under" in cold.message
    (heavy,) = condition_warnings(calibrated, version=3, temperatures=[], payloads_kg=[12.5])
    assert (heavy.condition, heavy.outside_by) == ("payload_kg", 2.5)
    assert condition_warnings(None, version=1, temperatures=[100.0], payloads_kg=[]) == []
    assert condition_warnings({"temperature_c": None}, version=1, temperatures=[100.0], payloads_kg=[]) == []


def test_the_history_carries_the_accuracy_and_exports_as_csv(client: TestClient, robot_id: str) -> None:
    """A check against the nominal tolerances: its RMS measured and predicted errors on the timeline, the same
    in the CSV export (by ?format=csv and by Accept)."""
    joints = sample_workspace(DESC, 6, seed=5)
    fk = forward_kinematics(DESC, joints)
    records = [
        {"joints": (joints[k] * DESC.joint_to_boundary).tolist(), "position": (fk.positions[k] + 0.01).tolist()}
        for k in range(6)
    ]
    check = client.post(f"/v1/robots/{robot_id}/checks", json={"measurements": records, "against": "tolerances"})
    assert check.status_code == 201, check.text
    per_record = check.json()["per_record"]
    (event,) = client.get(f"/v1/robots/{robot_id}/history").json()
    assert event["kind"] == "check" and event["id"] == check.json()["id"]
    assert event["rms_mm"] == pytest.approx(np.sqrt(np.mean([r["position_mm"] ** 2 for r in per_record])))
    assert event["predicted_mm"] == pytest.approx(np.sqrt(np.mean([r["predicted_mm"] ** 2 for r in per_record])))
    assert event["drift_mm"] is None
    for answer in (
        client.get(f"/v1/robots/{robot_id}/history?format=csv"),
        client.get(f"/v1/robots/{robot_id}/history", headers={"accept": "text/csv"}),
    ):
        assert answer.status_code == 200 and answer.headers["content-type"].startswith("text/csv")
        header, row = answer.text.splitlines()
        assert header == "at,kind,id,version,outcome,rms_mm,predicted_mm,drift_mm"
        cells = row.split(",")
        assert cells[1:5] == ["check", event["id"], "1", event["outcome"]]
        assert float(cells[5]) == event["rms_mm"] and float(cells[6]) == event["predicted_mm"] and cells[7] == ""
    assert client.get(f"/v1/robots/{robot_id}/history", headers={"accept": "image/png"}).status_code == 406


def _csv(sim: DriftCampaign, *, time: list[str], reference: list[str]) -> str:
    c = sim.drifted
    assert c.quaternions is not None
    names = ",".join(DESC.joint_names)
    lines = [f"{names},x,y,z,qw,qx,qy,qz,time,reference"]
    for k in range(c.size):
        cells = [*(c.joints[k] * DESC.joint_to_boundary).tolist(), *c.positions[k].tolist(), *c.quaternions[k].tolist()]
        lines.append(",".join([*map(repr, cells), time[k], reference[k]]))
    return "\n".join(lines)


@pytest.mark.slow  # a 40-record calibration fitted twice over HTTP
def test_a_csv_campaign_with_time_and_reference_columns(client: TestClient, robot_id: str) -> None:
    sim = drift_campaign(DESC, 3, noise=NOISE, records=40, every=5)
    marks = ["x" if k in sim.timeline.reference else "" for k in range(40)]
    seconds = [repr(float(t)) for t in sim.timeline.times_s]
    r = client.post(
        f"/v1/robots/{robot_id}/calibrations?drift=time&noise_position_mm=0.01&noise_orientation_deg=0.002",
        content=_csv(sim, time=seconds, reference=marks),
        headers={"content-type": "text/csv"},
    )
    assert r.status_code == 201, r.text
    drift = r.json()["drift"]
    assert drift["over"] == "seconds" and drift["reference_records"] == sim.timeline.reference.tolist()
    truth = sim.drift_mm[-1] - sim.drift_mm[0]
    assert np.all(np.abs(np.array(drift["over_campaign_mm"]) - truth) < 3.5 * np.array(drift["over_campaign_sigma_mm"]))


def test_a_csv_time_column_of_another_format_is_not_read_and_a_bad_mark_is_a_400(
    client: TestClient, robot_id: str, small: DriftCampaign
) -> None:
    marks = ["1" if k in small.timeline.reference else "0" for k in range(small.drifted.size)]
    instrument_format = [f"05.12.2026 08:{k:02d}" for k in range(small.drifted.size)]
    url = f"/v1/robots/{robot_id}/calibrations?drift=time&apply=false"
    marks[3] = "maybe"
    bad = client.post(
        url, content=_csv(small, time=instrument_format, reference=marks), headers={"content-type": "text/csv"}
    )
    assert bad.status_code == 400 and "mark a reference pose's row 1, true, yes or x" in bad.json()["detail"]
    assert client.get(f"/v1/robots/{robot_id}/calibrations").json() == []
    marks[3] = "0"
    records, notes = campaign_records(
        read_table(_csv(small, time=instrument_format, reference=marks)), DESC.joint_names, ImportOptions()
    )
    assert all("time" not in r for r in records) and any("time: every row needs seconds or an ISO" in n for n in notes)
    assert [k for k, r in enumerate(records) if r.get("reference")] == small.timeline.reference.tolist()
    iso = [f"2026-12-05T08:{k:02d}:00" for k in range(small.drifted.size)]
    records, _ = campaign_records(read_table(_csv(small, time=iso, reference=marks)), DESC.joint_names, ImportOptions())
    assert [r["time"] for r in records] == iso
