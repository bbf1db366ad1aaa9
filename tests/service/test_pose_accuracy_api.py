"""`POST …/forward-kinematics` with `accuracy`: the current version's predicted error at each joint vector, and
whether it lies in the region its calibration measured.

Truth: a UR5-like arm whose true parameters are known (`helpers.ur5_truth`), calibrated through the API from 40
position records in a box of joint space; the predictions are judged against the error the calibrated model
really makes at fresh poses, inside the box and with a joint turned away from it.
"""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from iwr_client.errors import ApiError
from models import forward_kinematics
from models.simulation import SimulatedRobot
from tests.service.helpers import UR5, InProcess, calibrate_robot, posted_ur5, records, ur5_truth

CENTER = np.array([10.0, -80.0, 70.0, -60.0, -90.0, 30.0])
HALF = np.array([40.0, 25.0, 30.0, 40.0, 40.0, 60.0])


def _fitted(answer: dict[str, object]) -> np.ndarray:
    return UR5.parameters.from_boundary([float(p["value"]) for p in answer["parameters"]])  # type: ignore[attr-defined]


@pytest.mark.slow  # ~1.5 s: one calibration and 400 predictions through the API
def test_each_pose_gets_its_prediction_and_the_poses_away_from_the_campaign_are_flagged(api: TestClient) -> None:
    rng = np.random.default_rng(3)
    truth = ur5_truth(11)
    sim = SimulatedRobot(UR5, UR5.parameters.nominal, truth)
    measured = CENTER + rng.uniform(-HALF, HALF, (40, 6))
    robot_id = posted_ur5(api, "ur5-accuracy")
    answer = calibrate_robot(
        api,
        robot_id,
        {
            "measurements": records(UR5, sim, np.radians(measured), seed=5, position_only=True),
            "noise": {"position_mm": 0.025},
        },
    )
    assert answer["applied"]
    inside = CENTER + rng.uniform(-0.9 * HALF, 0.9 * HALF, (300, 6))
    away = inside[:100].copy()
    away[:, 0] -= 130.0  # the base joint turned away from the measured -30…50°
    joints = np.vstack([inside, away])
    got = api.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": joints.tolist(), "accuracy": True})
    assert got.status_code == 200, got.text
    body = got.json()
    region = body["measured_region"]
    assert region["calibration_id"] == answer["id"] and region["version"] == answer["parameter_version"]
    assert region["poses"] == 40
    accuracy = body["accuracy"]
    assert len(accuracy) == 400
    predicted = np.array([a["position_mm"] for a in accuracy])
    q = np.radians(joints)
    error = np.linalg.norm(
        forward_kinematics(UR5, q, _fitted(answer)).positions - forward_kinematics(UR5, q, truth).positions, axis=1
    )
    # Inside: in the region, and the predicted RMS within 2× the RMS error the calibrated model makes there.
    assert np.mean([a["in_measured_region"] for a in accuracy[:300]]) > 0.95
    ratio = np.sqrt(np.mean(predicted[:300] ** 2)) / np.sqrt(np.mean(error[:300] ** 2))
    assert 0.5 < ratio < 2.0, ratio
    # The region's own figure is the calibration's measured-region prediction, from the same covariance.
    rms_region = answer["predicted_accuracy"]["measured_region_rms_position_mm"]
    assert region["rms_position_mm"] == pytest.approx(rms_region, rel=0.05)
    # Away: every pose flagged, naming the base joint and its measured span in degrees.
    assert not any(a["in_measured_region"] for a in accuracy[300:])
    for a in accuracy[300:]:
        assert a["extrapolation"].startswith("extrapolation: ")
        assert "outside the measured" in a["extrapolation"] and "°" in a["extrapolation"]
        assert a["distance_to_measured"] > 0.1


def test_an_uncalibrated_version_is_a_422_naming_accuracy(api: TestClient) -> None:
    robot_id = posted_ur5(api, "ur5-never-calibrated")
    # Through the Python client, as a user calls it.
    with pytest.raises(ApiError) as refused:
        InProcess(api).forward_kinematics(robot_id, [[0.0] * 6], accuracy=True)
    problem = refused.value.problem
    assert problem["status"] == 422 and problem["field"] == "accuracy"
    assert "calibrate the robot first" in problem["detail"]
    # Without it, the same request is an ordinary forward kinematics.
    plain = api.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": [[0.0] * 6]})
    assert plain.status_code == 200 and "accuracy" not in plain.json()


def test_more_joint_vectors_than_a_prediction_takes_are_refused(api: TestClient) -> None:
    robot_id = posted_ur5(api, "ur5-too-many")
    got = api.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": [[0.0] * 6] * 10_001, "accuracy": True})
    assert got.status_code == 422
    assert "at most 10000 joint vectors" in got.text
