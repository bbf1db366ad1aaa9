"""Through HTTP only: create the IWR, design 30 poses, measure them on a simulated robot, calibrate, check
the calibrated forward kinematics against the truth, and compensate targets."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.simulation import perturbed_robot
from models.transforms import matrix_to_quaternion
from tests.service.helpers import records

DESC = iwr()


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_design_measure_calibrate_compensate(client: TestClient) -> None:
    robot = client.post("/v1/robots", json={"name": "cell-7", "model": "iwr"}).json()
    rid = robot["id"]
    design = client.post(f"/v1/robots/{rid}/pose-designs", json={"count": 30, "criterion": "D", "candidate_count": 400})
    assert design.status_code == 201, design.text
    poses = np.array(design.json()["poses"]) / DESC.joint_to_boundary

    sim = perturbed_robot(DESC, seed=21)  # the real robot, and an instrument 3 m away
    calibration = client.post(
        f"/v1/robots/{rid}/calibrations", json={"measurements": records(DESC, sim, poses, seed=22)}
    )
    assert calibration.status_code == 201, calibration.text
    report = calibration.json()
    assert report["status"] == "succeeded" and report["parameter_version"] == 2
    assert report["residuals"]["after"]["rms_mm"] < report["residuals"]["before"]["rms_mm"] / 10

    fresh = sample_workspace(DESC, 50, seed=23)
    predicted = client.post(
        f"/v1/robots/{rid}/forward-kinematics", json={"joints": (fresh * DESC.joint_to_boundary).tolist()}
    ).json()["poses"]
    truth = forward_kinematics(DESC, fresh, sim.truth).positions
    error = np.linalg.norm(np.array([p["position"] for p in predicted]) - truth, axis=1)
    accuracy = report["predicted_accuracy"]["rms_position_mm"]
    assert np.sqrt(np.mean(error**2)) < 3 * accuracy and np.sqrt(np.mean(error**2)) < 0.1

    goal = forward_kinematics(DESC, sample_workspace(DESC, 10, seed=24), sim.truth)
    targets = [
        {"position": p.tolist(), "orientation": q.tolist()}
        for p, q in zip(goal.positions, matrix_to_quaternion(goal.rotations), strict=True)
    ]
    answer = client.post(f"/v1/robots/{rid}/inverse-kinematics", json={"targets": targets}).json()
    assert all(answer["reachable"])
    commanded = np.array(answer["joints"]) / DESC.joint_to_boundary
    reached = forward_kinematics(DESC, commanded, sim.truth).positions  # the real robot executes the commands
    miss = np.linalg.norm(reached - goal.positions, axis=1)
    assert np.sqrt(np.mean(miss**2)) < 3 * accuracy
