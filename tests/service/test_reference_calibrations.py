"""Calibrations from the instruments a cell owns, over HTTP: ballbar (distance), socket (point) and probe (plane)
records, alone or beside tracker positions, as JSON and as CSV; the answer against the simulated truth, and
the bad input that must be refused with nothing stored."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from harness.ballbar import PIVOTS, aligned_rms, ballbar_campaign, reaching
from harness.camera import WORLD_CAMERA, WORLD_CAMERA_POSITION, world_camera_campaign
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.description.structure import description_from_document
from models.formats.urdf import document_from_urdf
from models.identification.registration import rigid_fit
from models.measurements.references import ReferenceRecords
from tests.models.test_urdf import UR5_URDF
from tests.service.helpers import calibrate_robot, finished_job, posted_ur5

UR5 = ur5_like()
SIGMA_MM = 0.002
Campaign = tuple[np.ndarray, tuple[ReferenceRecords, ...]]


@pytest.fixture(scope="module")
def campaign() -> Campaign:
    return ballbar_campaign(UR5, 4, per_pivot=32, sigma_mm=SIGMA_MM)


@pytest.fixture
def arm(client: TestClient) -> str:
    return posted_ur5(client, "ur5-ballbar")


def _records(groups: tuple[ReferenceRecords, ...]) -> list[dict[str, Any]]:
    out = []
    for g in groups:
        joints = (g.joints * UR5.joint_to_boundary).tolist()
        for q, d in zip(joints, g.values, strict=True):
            out.append({"kind": "distance", "joints": q, "anchor": g.reference.name, "distance_mm": float(d)})
    return out


def _body(groups: tuple[ReferenceRecords, ...], **extra: Any) -> dict[str, Any]:
    anchors = {g.reference.name: {"length_unknown": getattr(g.reference, "length_unknown", False)} for g in groups}
    return {"measurements": _records(groups), "anchors": anchors, "noise": {"position_mm": SIGMA_MM}, **extra}


def _count(client: TestClient, robot: str) -> tuple[int, int]:
    calibrations = client.get(f"/v1/robots/{robot}/calibrations").json()
    versions = client.get(f"/v1/robots/{robot}/parameter-versions").json()
    return len(calibrations), len(versions)


def test_a_ballbar_campaign_calibrates_the_arm_and_reports_its_anchors(
    client: TestClient, arm: str, campaign: Campaign
) -> None:
    truth, groups = campaign
    report = calibrate_robot(client, arm, _body(groups))
    assert report["status"] == "succeeded" and report["applied"], report["not_applied_reason"]
    assert all(c["passed"] for c in report["checks"]), report["checks"]
    assert report["record_kinds"] == {"distance": 3 * 32}
    assert "base" in report["frame"] and report["measurement"] == "position"
    assert {n for n in report["unidentifiable"] if n.startswith("base.")} == {
        f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")
    }
    assert report["residuals"]["after"]["rms_mm"] < 3 * SIGMA_MM
    fresh = sample_workspace(UR5, 200, seed=77)
    true = forward_kinematics(UR5, fresh, truth).positions
    fitted = [float(p["value"]) for p in report["parameters"]]
    fitted_positions = forward_kinematics(UR5, fresh, UR5.parameters.from_boundary(fitted)).positions
    nominal_positions = forward_kinematics(UR5, fresh, UR5.parameters.nominal).positions
    assert aligned_rms(fitted_positions, true) < 0.01 < aligned_rms(nominal_positions, true)
    # The anchors, identified in the frame the held parameters leave (the base, the first joint's offsets): the
    # rigid motion that aligns the fitted robot with the true one takes them onto the pivots, within four
    # standard errors; the unknown bar offset likewise.
    motion = rigid_fit(fitted_positions, true)
    for ref, pivot in zip(report["references"], PIVOTS, strict=True):
        assert ref["kind"] == "anchor" and ref["records"] == 32
        std = np.array([u["std_error"] for u in ref["unknowns"][:3]])
        moved = motion.apply(np.array([ref["position_mm"]]))[0]
        assert np.linalg.norm(moved - pivot) < 4 * np.linalg.norm(std), (ref, pivot)
    offset = report["references"][2]
    assert offset["length_offset_mm"] == pytest.approx(0.35, abs=4 * offset["unknowns"][3]["std_error"])


def test_a_misread_distance_is_named_by_its_place_in_the_campaign(
    client: TestClient, arm: str, campaign: Campaign
) -> None:
    _, groups = campaign
    body = _body(groups)
    blunder = 40  # the ninth record of the second anchor
    body["measurements"][blunder]["distance_mm"] += 0.5
    report = client.post(f"/v1/robots/{arm}/calibrations", json=body).json()
    assert [(o["pose"], o["excluded"]) for o in report["outliers"]] == [(blunder, True)]
    assert report["outliers"][0]["position_mm"] == pytest.approx(0.5, abs=0.05)
    assert report["residuals"]["before"]["per_pose_mm"][blunder] > 0.3


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_csv_layout_of_several_kinds_gives_the_json_answer(
    client: TestClient, arm: str, campaign: Campaign
) -> None:
    _, groups = campaign
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\r\n")
    writer.writerow(["kind", "anchor", *[f"A{k + 1}" for k in range(6)], "distance [m]"])
    for r in _records(groups):
        writer.writerow(["distance", r["anchor"], *r["joints"], repr(r["distance_mm"] / 1000.0)])
    query: dict[str, str | float] = {"noise_position_mm": SIGMA_MM, "length_unknown": "a3", "apply": "false"}
    from_csv = client.post(
        f"/v1/robots/{arm}/calibrations", content=out.getvalue(), params=query, headers={"content-type": "text/csv"}
    )
    assert from_csv.status_code == 201, from_csv.text
    from_json = client.post(f"/v1/robots/{arm}/calibrations", json=_body(groups, apply=False)).json()
    got = np.array([p["value"] for p in from_csv.json()["parameters"]])
    np.testing.assert_allclose(got, [p["value"] for p in from_json["parameters"]], atol=1e-9)
    assert any("distances converted to mm" in n for n in from_csv.json()["notes"])
    # The stored campaign comes back as received, and in the same layout.
    campaign_id = from_csv.json()["campaign_id"]
    stored = client.get(f"/v1/campaigns/{campaign_id}").json()["measurements"]
    assert stored[0]["kind"] == "distance" and stored[0]["anchor"] == "a1"
    table = client.get(f"/v1/campaigns/{campaign_id}", params={"format": "csv"}).text.splitlines()
    assert table[0].startswith("kind,reference,") and table[1].startswith("distance,a1,")


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_points_and_planes_beside_tracker_positions_fix_the_frame(client: TestClient, arm: str) -> None:
    truth = ur5_like().parameters.nominal.copy()
    rng = np.random.default_rng(5)
    truth[6:] += rng.normal(0, 0.2, truth.size - 6) * UR5.parameters.scales[6:]
    joints = sample_workspace(UR5, 40, seed=9)
    tracked = forward_kinematics(UR5, joints, truth).positions + rng.normal(0, SIGMA_MM, (40, 3))
    deg = joints * UR5.joint_to_boundary
    records: list[dict[str, Any]] = [
        {"joints": q.tolist(), "position": p.tolist(), "sigma_mm": SIGMA_MM} for q, p in zip(deg, tracked, strict=True)
    ]
    # A plate z = 120 touched at 12 places: the tracker's records say where the TCP is, so these must agree.
    on_plate = np.column_stack([rng.uniform(150, 450, 16), rng.uniform(-300, 300, 16), np.full(16, 120.0)])
    touches = reaching(UR5, truth, on_plate, 11)[:12]
    assert touches.shape[0] == 12
    records += [{"kind": "plane", "joints": q.tolist(), "plane": "table"} for q in touches * UR5.joint_to_boundary]
    body = {"measurements": records, "noise": {"position_mm": SIGMA_MM}, "planes": {"table": {"normal": [0, 0, 1]}}}
    report = calibrate_robot(client, arm, body)
    assert report["record_kinds"] == {"position": 40, "plane": 12}
    assert not any(n.startswith("base.") for n in report["unidentifiable"])  # the tracker fixes the frame
    plane = report["references"][1]
    assert plane["kind"] == "plane" and plane["normal"][2] > 0.9
    assert plane["offset_mm"] == pytest.approx(120.0, abs=4 * plane["unknowns"][2]["std_error"])


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(
    ("change", "status", "words"),
    [
        (lambda b: b["anchors"].pop("a2"), 400, "does not describe"),
        (lambda b: b["anchors"].update({"spare": {}}), 400, "no record measures it"),
        (lambda b: b["measurements"][0].update({"kind": "ballbar"}), 422, "kind is one of"),
        (lambda b: b["measurements"][0].pop("distance_mm"), 422, "distance_mm"),
        (
            lambda b: b.update({"measurements": b["measurements"][:3] + b["measurements"][32:]}),
            422,
            "'a1' has 3 records",
        ),
        (lambda b: b["measurements"][5].update({"joints": [0.0, 0.0, 0.0]}), 422, "joint"),
    ],
)
def test_bad_reference_campaigns_are_refused_and_nothing_is_stored(
    client: TestClient, arm: str, campaign: Campaign, change: Any, status: int, words: str
) -> None:
    _, groups = campaign
    body = _body(groups, options={})
    change(body)
    before = _count(client, arm)
    answer = client.post(f"/v1/robots/{arm}/calibrations", json=body)
    assert answer.status_code == status, answer.text
    assert words in answer.text
    assert _count(client, arm) == before


def test_a_plane_touched_along_a_line_is_refused_naming_it(client: TestClient, arm: str, campaign: Campaign) -> None:
    _, groups = campaign
    body = _body(groups)
    # One pose touched eight times: a point, which no plane can be fitted to.
    line = np.tile([10.0, -60.0, 60.0, -30.0, 40.0, 20.0], (8, 1))
    body["measurements"] += [{"kind": "plane", "joints": q.tolist(), "plane": "f1"} for q in line]
    answer = client.post(f"/v1/robots/{arm}/calibrations", json=body)
    assert answer.status_code == 422 and "plane 'f1'" in answer.text, answer.text


@pytest.mark.slow  # a job, its report in HTML and PDF: about three seconds
def test_a_ballbar_calibration_runs_as_a_job_and_reports_its_anchors(
    client: TestClient, arm: str, campaign: Campaign
) -> None:
    _, groups = campaign
    accepted = client.post(f"/v1/robots/{arm}/calibrations?async=true", json=_body(groups))
    assert accepted.status_code == 202, accepted.text
    job = finished_job(client, f"/v1/jobs/{accepted.json()['job_id']}")
    assert job["status"] == "succeeded", job
    calibration = job["result"]
    assert [r["name"] for r in calibration["references"]] == ["a1", "a2", "a3"]
    page = client.get(f"/v1/calibrations/{calibration['id']}/report", headers={"Accept": "text/html"})
    assert page.status_code == 200 and "<h2>References</h2>" in page.text
    # Every anchor's identified position as the report states it (to the report's 4 decimals).
    for ref in calibration["references"]:
        assert ", ".join(f"{v:.4f}" for v in ref["position_mm"]) in page.text
    pdf = client.get(f"/v1/calibrations/{calibration['id']}/report?format=pdf")
    assert pdf.status_code == 200 and pdf.content.startswith(b"%PDF")


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_ballbar_validation_tells_the_calibrated_version_from_the_nominal(
    client: TestClient, arm: str, campaign: Campaign
) -> None:
    truth, groups = campaign
    assert client.post(f"/v1/robots/{arm}/calibrations", json=_body(groups)).json()["parameter_version"] == 2
    # A fresh ballbar run on the same robot: other poses, the first pivot, exact distances plus the bar's noise.
    joints = sample_workspace(UR5, 30, seed=500)
    rng = np.random.default_rng(500)
    d = np.linalg.norm(forward_kinematics(UR5, joints, truth).positions - PIVOTS[0], axis=1)
    d += rng.normal(0, SIGMA_MM, d.size)
    records = [
        {"kind": "distance", "joints": q.tolist(), "anchor": "check", "distance_mm": float(v)}
        for q, v in zip(joints * UR5.joint_to_boundary, d, strict=True)
    ]
    body = {"measurements": records, "anchors": {"check": {}}, "versions": [1, 2]}
    answer = client.post(f"/v1/robots/{arm}/validations", json=body)
    assert answer.status_code == 201, answer.text
    nominal, calibrated = answer.json()["results"]
    assert calibrated["registered"] and len(calibrated["per_pose"]) == 30
    # With the anchor placed, the calibrated version misses by the bar's noise, the nominal by tenths of a mm.
    assert calibrated["position_mm"]["rms"] < 2 * SIGMA_MM < 0.05 < nominal["position_mm"]["rms"]
    stored = client.get(f"/v1/campaigns/{answer.json()['campaign_id']}").json()["measurements"]
    assert stored[0]["anchor"] == "check"


# ---------------------------------------------------------------------------------------------- camera


def _images_body(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The harness's image records (joints in internal units) as the API takes them (degrees)."""
    out = []
    for r in records:
        q = (np.asarray(r["joints"]) * UR5.joint_to_boundary).tolist()
        out.append({**r, "joints": q})
    return {"measurements": out, "cameras": WORLD_CAMERA, "noise": {"position_mm": 0.05}}


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_world_camera_calibrates_the_arm_and_finds_its_own_pose(client: TestClient, arm: str) -> None:
    seen = world_camera_campaign(UR5, 2, images=30)
    report = calibrate_robot(client, arm, _images_body(seen.images))
    assert report["status"] == "succeeded" and report["noise_consistent"], report["checks"]
    assert report["record_kinds"] == {"image": 30} and report["measurements"] == 30
    [camera] = report["references"]
    assert camera["kind"] == "image" and camera["records"] == 30 * 4  # one per seen point
    std = np.array([u["std_error"] for u in camera["unknowns"][:3]])
    assert np.linalg.norm(np.array(camera["position_mm"]) - WORLD_CAMERA_POSITION) < 5 * np.linalg.norm(std)
    # Each image's error is its points' reprojection error carried to their depth: tens of µm at 1.5 m for 0.1 px.
    assert len(report["residuals"]["after"]["per_pose_mm"]) == 30
    assert report["residuals"]["after"]["rms_mm"] < 0.2 < report["residuals"]["before"]["rms_mm"]
    # The stored campaign and its CSV, and the CSV read back with the camera described beside it.
    campaign_id = report["campaign_id"]
    table = client.get(f"/v1/campaigns/{campaign_id}", params={"format": "csv"}).text
    assert table.count("\nimage,c1,") == 30 * 4
    again = client.post(
        f"/v1/robots/{arm}/calibrations",
        files={"records": ("images.csv", table), "descriptions": (None, json.dumps({"cameras": WORLD_CAMERA}))},
        params={"apply": "false"},
    )
    assert again.status_code == 201, again.text
    np.testing.assert_allclose(
        [p["value"] for p in again.json()["parameters"]], [p["value"] for p in report["parameters"]], atol=1e-6
    )


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda b: b.update({"cameras": {}}), "does not describe"),
        (lambda b: b["measurements"][3].update({"points": []}), "at least 1"),
        (lambda b: b["cameras"]["c1"].update({"fx": 12.0, "fy": 12.0}), "pixels"),
        (lambda b: [p.update({"pixel": p["pixel"][::-1]}) for r in b["measurements"] for p in r["points"]], "(v, u)"),
    ],
)
def test_bad_image_campaigns_are_refused_and_nothing_is_stored(
    client: TestClient, arm: str, change: Any, words: str
) -> None:
    seen = world_camera_campaign(UR5, 3, images=12)
    body = json.loads(json.dumps(_images_body(seen.images)))
    change(body)
    before = _count(client, arm)
    answer = client.post(f"/v1/robots/{arm}/calibrations", json=body)
    assert 400 <= answer.status_code < 500 and words in answer.text, answer.text
    assert _count(client, arm) == before


EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "instruments"


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_example_files_calibrate_the_example_robot(client: TestClient) -> None:
    robot = client.post("/v1/robots", json=json.loads((EXAMPLES / "ur5_robot.json").read_text())).json()["id"]
    ballbar = client.post(
        f"/v1/robots/{robot}/calibrations",
        content=(EXAMPLES / "ballbar.csv").read_text(),
        params={"length_unknown": "a3", "noise_position_mm": SIGMA_MM, "apply": "false"},
        headers={"content-type": "text/csv"},
    ).json()
    assert ballbar["status"] == "succeeded" and all(c["passed"] for c in ballbar["checks"]), ballbar["checks"]
    assert ballbar["record_kinds"] == {"distance": 108}
    # Not applied: the camera's campaign below is judged against the nominal version, not against this one's.
    probed = {**json.loads((EXAMPLES / "probe_and_sockets.json").read_text()), "apply": False}
    probe = client.post(f"/v1/robots/{robot}/calibrations", json=probed)
    report = probe.json()
    assert probe.status_code == 201 and report["status"] == "succeeded", probe.text
    assert all(c["passed"] for c in report["checks"]), report["checks"]
    assert report["record_kinds"] == {"point": 20, "plane": 30, "distance": 30}
    assert report["residuals"]["after"]["rms_mm"] < 3 * SIGMA_MM < report["residuals"]["before"]["rms_mm"]
    images = client.post(f"/v1/robots/{robot}/calibrations", json=json.loads((EXAMPLES / "camera.json").read_text()))
    assert images.status_code == 201 and images.json()["record_kinds"] == {"image": 30}, images.text
    assert all(c["passed"] for c in images.json()["checks"]), images.json()["checks"]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_urdf_imported_arm_calibrates_from_a_ballbar(client: TestClient) -> None:
    """Any structure: the arm imported from a URDF (its chain re-described from the joint axes) takes the
    same records; the calibrated model predicts the true TCP at fresh poses to micrometres after alignment."""
    made = client.post(
        "/v1/robots", json={"name": "ur5-urdf", "urdf": UR5_URDF, "base_link": "world", "tip_link": "tool0"}
    )
    assert made.status_code == 201, made.text
    desc = description_from_document(document_from_urdf(UR5_URDF, "world", "tool0"))
    truth, groups = ballbar_campaign(desc, 7, per_pivot=36, sigma_mm=SIGMA_MM)
    body = _body(groups)
    for record, q in zip(
        body["measurements"], np.vstack([g.joints for g in groups]) * desc.joint_to_boundary, strict=True
    ):
        record["joints"] = q.tolist()
    answer = client.post(f"/v1/robots/{made.json()['id']}/calibrations", json=body)
    assert answer.status_code == 201, answer.text
    report = answer.json()
    assert report["status"] == "succeeded" and all(c["passed"] for c in report["checks"]), report["checks"]
    fresh = sample_workspace(desc, 200, seed=70)
    fitted = desc.parameters.from_boundary([float(p["value"]) for p in report["parameters"]])
    true = forward_kinematics(desc, fresh, truth).positions
    assert aligned_rms(forward_kinematics(desc, fresh, fitted).positions, true) < 0.01
