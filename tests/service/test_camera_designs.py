"""Pose design for a calibrated camera's images over HTTP (`"measurement": "image"`): a candidate pose is the
image the camera would take there (the targets in front of it and on its image, from the body's guess of its
pose). The API's design is the library's on the same candidates and predicts less than random images; a target
design answers how many; images simulated at the chosen poses on a perturbed arm and calibrated through the API
reach what the design predicted; bad input is refused naming what to fix, and nothing is stored."""

from __future__ import annotations

import copy
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from harness.camera import (
    HAND_EYE_POSITION,
    INTRINSICS,
    MARKERS,
    WORLD_CAMERA,
    WORLD_CAMERA_POSITION,
    WORLD_CAMERA_ROTATION,
    board,
    camera_gauge_truth,
    project,
    world_images,
)
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.measurements.camera import Camera, Intrinsics
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from optimal_design.references import camera_candidates, design_reference_records
from tests.service.helpers import assert_design_kept, calibrate_robot, posted_ur5, ur5_tcp_error_mm

UR5 = ur5_like()
SIGMA_PX = 0.1
ROTATION_DEG = [math.degrees(v) for v in matrix_to_rotvec_np(WORLD_CAMERA_ROTATION)]
DESIGNED = {
    **WORLD_CAMERA["c1"],
    "position_mm": WORLD_CAMERA_POSITION.tolist(),
    "rotation_vector_deg": ROTATION_DEG,
    "targets_mm": MARKERS.tolist(),
}
"""The harness's world camera as a design describes it: its intrinsics, a guess of its pose, its markers."""


@pytest.fixture
def arm(client: TestClient) -> str:
    return posted_ur5(client, "ur5-camera-design")


def _joints(n: int, seed: int = 42) -> np.ndarray:
    return sample_workspace(UR5, n, seed=seed)


def _body(joints: np.ndarray, **extra: Any) -> dict[str, Any]:
    return {
        "measurement": "image",
        "count": 20,
        "criterion": "I",
        "candidates": (joints * UR5.joint_to_boundary).tolist(),
        "cameras": {"c1": copy.deepcopy(DESIGNED)},
        **extra,
    }


def _design(client: TestClient, arm: str, body: dict[str, Any]) -> dict[str, Any]:
    answer = client.post(f"/v1/robots/{arm}/pose-designs", json=body)
    assert answer.status_code == 201, answer.text
    return dict(answer.json())


def _seen(joints: np.ndarray) -> np.ndarray:
    """(N, markers): which markers the camera sees at each pose under the nominal model, written out with the
    harness's numpy projection (in front of it and on its 2048 × 1536 image)."""
    fk = forward_kinematics(UR5, joints)
    world = np.einsum("nij,mj->nmi", fk.rotations, MARKERS) + fk.positions[:, None, :]
    cam = (world - WORLD_CAMERA_POSITION) @ WORLD_CAMERA_ROTATION
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = project(cam.reshape(-1, 3), INTRINSICS).reshape(len(joints), len(MARKERS), 2)
    u, v = pixels[..., 0], pixels[..., 1]
    return np.asarray((cam[..., 2] > 0) & (u >= 0) & (u <= 2048) & (v >= 0) & (v <= 1536))


def _calibrated_error(client: TestClient, arm: str, design: dict[str, Any], seed: int) -> float:
    """The chosen images simulated on a perturbed truth (in the gauge a world camera leaves free: no alignment
    needed) and calibrated through the API: the TCP error on fresh poses, mm."""
    truth = camera_gauge_truth(UR5, seed)
    joints = np.asarray(design["poses"]) / UR5.joint_to_boundary
    images, _ = world_images(UR5, truth, joints, np.random.default_rng(seed), sigma_px=SIGMA_PX)
    records = [{**r, "joints": (np.asarray(r["joints"]) * UR5.joint_to_boundary).tolist()} for r in images]
    body = {"measurements": records, "cameras": WORLD_CAMERA, "apply": False}
    return ur5_tcp_error_mm(calibrate_robot(client, arm, body), truth)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_an_i_design_of_20_images_is_the_librarys_and_calibrates_to_its_prediction(
    client: TestClient, arm: str
) -> None:
    joints = _joints(160)
    report = _design(client, arm, _body(joints))
    assert report["measurement"] == "image" and report["count"] == 20
    assert report["references"] == ["c1"] * 20
    metrics, baseline = report["metrics"], report["random_baseline"]
    assert metrics["predicted_rms_tcp_mm"] < 0.8 * baseline["predicted_rms_tcp_mm"], (metrics, baseline)
    # The library on the same candidates, its camera placed as the body guesses it (the robot is fresh: its
    # current parameters are the nominal ones, and without `noise` both take the models' default).
    lens = Intrinsics(
        **{k: INTRINSICS[k] for k in ("fx", "fy", "cx", "cy")}, distortion=tuple(INTRINSICS["distortion"])
    )
    rx, ry, rz = (math.radians(v) for v in ROTATION_DEG)
    x, y, z = WORLD_CAMERA_POSITION
    camera = Camera("c1", lens, (x, y, z), (rx, ry, rz))
    images = camera_candidates(UR5, camera, joints, MARKERS, sigma_px=SIGMA_PX, params=UR5.parameters.nominal)
    library = design_reference_records(UR5, (images,), 20, "I", noise=NoiseModel(), params=UR5.parameters.nominal)
    seen = _seen(joints).any(axis=1)
    assert report["candidates"] == int(seen.sum()) < joints.shape[0]
    assert report["constraints"]["excluded"] == {"not_seen": int((~seen).sum())}
    # The library's indices count the poses that see anything; the API's count the candidates as given.
    assert report["indices"] == [int(i) for i in np.flatnonzero(seen)[list(library.indices)]]
    assert report["value"] == pytest.approx(library.value, abs=1e-9)
    assert metrics["predicted_rms_tcp_mm"] == pytest.approx(library.metrics["predicted_rms_tcp_mm"], abs=1e-9)
    np.testing.assert_allclose(report["poses"], joints[report["indices"]] * UR5.joint_to_boundary, atol=1e-9)
    assert_design_kept(client, arm, report, "image")
    # Close the loop: a calibration of those images reaches what the design predicts.
    reached = _calibrated_error(client, arm, report, seed=3)
    predicted = metrics["predicted_rms_tcp_mm"]
    assert predicted / 2 <= reached <= 2 * predicted, (reached, predicted)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_prediction_scales_with_the_cameras_sigma(client: TestClient, arm: str) -> None:
    joints = _joints(80, seed=7)
    plain = _design(client, arm, _body(joints, count=12))
    body = _body(joints, count=12)
    body["cameras"]["c1"]["sigma_px"] = 0.3
    noisy = _design(client, arm, body)
    # Every row of an image scales with 1/σ: the same images are chosen, and they predict thrice the error.
    assert noisy["indices"] == plain["indices"]
    ratio = noisy["metrics"]["predicted_rms_tcp_mm"] / plain["metrics"]["predicted_rms_tcp_mm"]
    assert ratio == pytest.approx(3.0, rel=1e-6)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_target_design_says_how_many_images(client: TestClient, arm: str) -> None:
    joints = _joints(80, seed=7)
    twelve = _design(client, arm, _body(joints, count=12))["metrics"]["predicted_rms_tcp_mm"]
    goal = 0.9 * twelve  # a little better than twelve designed images
    report = _design(client, arm, _body(joints, count=None, target={"rms_tcp_mm": goal}))
    assert report["criterion"] == "I" and report["measurement"] == "image"
    assert report["metrics"]["predicted_rms_tcp_mm"] <= goal
    assert report["count"] > 12 and len(report["poses"]) == report["count"] == len(report["references"])
    curve = {p["count"]: p for p in report["curve"]}
    assert curve[report["count"] - 1]["I_rms_tcp_mm"] > goal  # the smallest count: one image fewer misses it


def test_sampled_poses_are_kept_where_the_camera_sees_a_marker(client: TestClient, arm: str) -> None:
    count = 120
    body = _body(_joints(1), candidates=None, candidate_count=count, seed=5, count=15)
    report = _design(client, arm, body)
    sampled = sample_workspace(UR5, count, seed=5, params=UR5.parameters.nominal)
    seen = _seen(sampled)
    assert report["indices"] is None and report["constraints"]["offered"] == count
    assert report["constraints"]["excluded"] == {"not_seen": int((~seen.any(axis=1)).sum())}
    assert report["candidates"] == int(seen.any(axis=1).sum())
    # Every chosen pose is one that shows the camera a marker.
    chosen = np.asarray(report["poses"]) / UR5.joint_to_boundary
    assert _seen(chosen).any(axis=1).all()


def test_a_repeated_pose_is_one_candidate_image_named_by_its_first_place(client: TestClient, arm: str) -> None:
    joints = _joints(60, seed=7)
    seen = np.flatnonzero(_seen(joints).any(axis=1))
    repeated = np.vstack([joints, joints[seen[:5]]])  # five poses that see a marker, offered twice
    report = _design(client, arm, _body(repeated, count=12))
    assert report["candidates"] == seen.size
    assert report["constraints"]["excluded"] == {"not_seen": joints.shape[0] - seen.size}
    assert max(report["indices"]) < joints.shape[0] and len(set(report["indices"])) == 12
    np.testing.assert_allclose(report["poses"], joints[report["indices"]] * UR5.joint_to_boundary, atol=1e-9)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_camera_on_the_tool_is_designed_against_a_board(client: TestClient, arm: str) -> None:
    hand = {
        **INTRINSICS,
        "mount": "tool",
        "position_mm": HAND_EYE_POSITION.tolist(),
        "rotation_vector_deg": [0.0, 0.0, 0.0],  # looking along the tool's z axis
        "targets_mm": board().tolist(),
    }
    body = {"measurement": "image", "count": 15, "candidate_count": 300, "seed": 2, "cameras": {"hand": hand}}
    report = _design(client, arm, body)
    assert report["references"] == ["hand"] * 15
    assert 15 < report["candidates"] < 300 and report["constraints"]["excluded"]["not_seen"] > 0
    assert report["metrics"]["predicted_rms_tcp_mm"] < report["random_baseline"]["predicted_rms_tcp_mm"]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_images_are_designed_beside_a_ballbar(client: TestClient, arm: str) -> None:
    joints = _joints(60, seed=11)
    ballbar = sample_workspace(UR5, 30, seed=12) * UR5.joint_to_boundary
    candidates = [
        *({"joints": q.tolist(), "camera": "c1"} for q in joints * UR5.joint_to_boundary),
        *({"joints": q.tolist(), "anchor": "a1"} for q in ballbar),
    ]
    body = _body(joints, candidates=candidates, anchors={"a1": {"position_mm": [450, 150, 50]}}, count=25)
    body["noise"] = {"position_mm": 0.002}
    report = _design(client, arm, body)
    assert set(report["references"]) == {"c1", "a1"}  # both are worth taking
    for i, name in zip(report["indices"], report["references"], strict=True):
        assert candidates[i].get("camera", candidates[i].get("anchor")) == name


def _facing_away(body: dict[str, Any]) -> None:
    """The camera turned round: looking along +x, away from the robot (its x right = −y, its y down = −z)."""
    away = np.column_stack([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0]])
    body["cameras"]["c1"]["rotation_vector_deg"] = [math.degrees(v) for v in matrix_to_rotvec_np(away)]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda b: b["cameras"]["c1"].pop("position_mm"), "camera 'c1': a design needs a guess of where it is"),
        (lambda b: b["cameras"]["c1"].pop("rotation_vector_deg"), "rotation_vector_deg"),
        (lambda b: b["cameras"]["c1"].pop("targets_mm"), "camera 'c1': a design needs the points it would see"),
        (_facing_away, "camera 'c1' sees none of its 4 targets"),
        (lambda b: b.update({"candidates": [{"joints": b["candidates"][0], "camera": "c2"}]}), "camera 'c2'"),
        (
            lambda b: b.update({"cameras": {}, "candidates": None, "anchors": {"a1": {"position_mm": [450, 150, 50]}}}),
            "describe the cameras",
        ),
        (lambda b: b.update({"measurement": "pose"}), "is a tracker's"),
        (lambda b: b["cameras"]["c1"].update({"fx": 12.0, "fy": 12.0}), "pixels"),
    ],
)
def test_bad_camera_designs_are_refused_naming_the_fix_and_nothing_is_stored(
    client: TestClient, arm: str, change: Any, words: str
) -> None:
    body = _body(_joints(40))
    change(body)
    answer = client.post(f"/v1/robots/{arm}/pose-designs", json=body)
    assert 400 <= answer.status_code < 500, answer.text
    assert words in answer.text, answer.text
    assert client.get(f"/v1/robots/{arm}/pose-designs").json() == []


def test_the_documented_image_design_is_the_harness_camera_and_designs(client: TestClient, arm: str) -> None:
    text = (Path(__file__).resolve().parents[2] / "docs" / "instruments.md").read_text()
    section = text[text.index("### Images (image)") :]
    body = json.loads(re.findall(r"```json\n(.*?)```", section, re.DOTALL)[0])
    camera = body["cameras"]["c1"]
    # The documented guess is the harness's camera: its pose to the example's rounding, its markers.
    turned = rotvec_to_matrix_np(np.radians(camera["rotation_vector_deg"]))
    np.testing.assert_allclose(turned, WORLD_CAMERA_ROTATION, atol=1e-4)
    np.testing.assert_allclose(camera["position_mm"], WORLD_CAMERA_POSITION)
    np.testing.assert_allclose(camera["targets_mm"], MARKERS)
    report = _design(client, arm, {**body, "candidate_count": 150})  # fewer than documented: a fast test
    assert report["count"] == 20 and report["references"] == ["c1"] * 20
    assert report["metrics"]["predicted_rms_tcp_mm"] < report["random_baseline"]["predicted_rms_tcp_mm"]
