"""A calibration starts from a parameter version and keeps what it does not estimate (api.md, parameter versions).

The scenario that used to destroy a user's work: a good full calibration, then the tracker is moved and only the
base is re-fitted. The re-fit must keep every calibrated link, leg and the tool to the last digit, register the new
instrument frame, and predict as well as the full calibration did.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.simulation import SimulatedRobot, perturbed_robot
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from tests.service.helpers import records

DESC = iwr()


STATION_MOVE_ROTATION = rotvec_to_matrix_np(np.array([0.2, -0.1, 0.4]))
STATION_MOVE_SHIFT = np.array([850.0, -1200.0, 40.0])


def _moved(base: np.ndarray) -> np.ndarray:
    """A base (world ← robot: x, y, z, rotation vector) seen from the new station: new world ← old world ∘ base."""
    rotation = STATION_MOVE_ROTATION @ rotvec_to_matrix_np(base[3:])
    return np.asarray(np.r_[STATION_MOVE_ROTATION @ base[:3] + STATION_MOVE_SHIFT, matrix_to_rotvec_np(rotation)])


def _moved_instrument(sim: SimulatedRobot) -> SimulatedRobot:
    """The same real robot seen from another tracker station: only the base transform (world ← robot) changes."""
    truth = sim.truth.copy()
    truth[DESC.slices["base"]] = _moved(truth[DESC.slices["base"]])
    return replace(sim, truth=truth)


def _validation_error(client: TestClient, robot_id: str, sim: SimulatedRobot, seed: int) -> float:
    """RMS TCP position error of the robot's current version against the truth on fresh poses (mm)."""
    joints = sample_workspace(DESC, 50, seed=seed)
    answer = client.post(
        f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": (joints * DESC.joint_to_boundary).tolist()}
    )
    assert answer.status_code == 200, answer.text
    predicted = np.array([p["position"] for p in answer.json()["poses"]])
    truth = forward_kinematics(DESC, joints, sim.truth).positions
    return float(np.sqrt(np.mean(np.sum((predicted - truth) ** 2, axis=1))))


def _values(client: TestClient, robot_id: str, version: int | None = None) -> dict[str, float]:
    query = "" if version is None else f"?version={version}"
    params = client.get(f"/v1/robots/{robot_id}/parameters{query}").json()["parameters"]
    return {p["name"]: p["value"] for p in params}


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_base_only_refit_keeps_the_calibrated_geometry(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=21)
    full = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        json={"measurements": records(DESC, sim, sample_workspace(DESC, 60, seed=22), seed=23)},
    ).json()
    assert full["status"] == "succeeded" and full["parameter_version"] == 2 and full["start_version"] == 1
    after_full = _validation_error(client, robot_id, sim, seed=24)
    calibrated = _values(client, robot_id)

    moved = _moved_instrument(sim)
    refit = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        json={
            "measurements": records(DESC, moved, sample_workspace(DESC, 30, seed=25), seed=26),
            "options": {"estimate": ["base"]},
        },
    ).json()
    assert refit["status"] == "succeeded", refit
    assert refit["start_version"] == 2 and refit["parameter_version"] == 3
    assert refit["identifiable"] == [f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]

    current = _values(client, robot_id)
    kept = [n for n in current if not n.startswith("base.")]
    assert len(kept) == 64 and all(current[n] == calibrated[n] for n in kept)  # to the last digit
    # Re-registered: the new base is the calibrated one carried by the station's move (about 1.5 m and 26°).
    names = [f"base.{c}" for c in ("x", "y", "z", "rx", "ry", "rz")]
    old_base = np.array([calibrated[n] for n in names]) * np.r_[1, 1, 1, np.full(3, np.pi / 180)]
    new_base = np.array([current[n] for n in names]) * np.r_[1, 1, 1, np.full(3, np.pi / 180)]
    expected = _moved(old_base)
    assert np.linalg.norm(new_base[:3] - expected[:3]) < 0.05
    tilt = rotvec_to_matrix_np(new_base[3:]).T @ rotvec_to_matrix_np(expected[3:])
    assert np.degrees(np.arccos(np.clip((np.trace(tilt) - 1) / 2, -1, 1))) < 0.005

    after_refit = _validation_error(client, robot_id, moved, seed=24)
    nominal_error = _validation_error_of(DESC.parameters.nominal, moved, seed=24)
    assert after_refit < 1.3 * after_full, (after_refit, after_full)
    assert after_refit < nominal_error / 20

    # Each parameter the re-fit did not estimate keeps the full calibration's standard error too.
    params = client.get(f"/v1/robots/{robot_id}/parameters").json()["parameters"]
    before = {p["name"]: p for p in client.get(f"/v1/robots/{robot_id}/parameters?version=2").json()["parameters"]}
    for p in params:
        if not p["name"].startswith("base."):
            assert (
                p["std_error"] == before[p["name"]]["std_error"]
                and p["identifiable"] == before[p["name"]]["identifiable"]
            )


def _validation_error_of(theta: np.ndarray, sim: SimulatedRobot, seed: int) -> float:
    joints = sample_workspace(DESC, 50, seed=seed)
    predicted = forward_kinematics(DESC, joints, theta).positions
    truth = forward_kinematics(DESC, joints, sim.truth).positions
    return float(np.sqrt(np.mean(np.sum((predicted - truth) ** 2, axis=1))))


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_start_version_is_chosen_and_checked(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=31)
    recs = records(DESC, sim, sample_workspace(DESC, 50, seed=32), seed=33)
    assert client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs}).status_code == 201
    # Explicitly from the nominal version 1: a base-only fit then keeps the nominal geometry, as asked.
    from_nominal = client.post(
        f"/v1/robots/{robot_id}/calibrations",
        json={"measurements": recs, "options": {"estimate": ["base"]}, "start_version": 1, "apply": False},
    ).json()
    assert from_nominal["start_version"] == 1 and not from_nominal["applied"]
    nominal = dict(zip(DESC.parameters.names, DESC.parameters.as_boundary(DESC.parameters.nominal), strict=True))
    values = {p["name"]: p["value"] for p in from_nominal["parameters"]}
    assert all(values[n] == nominal[n] for n in values if not n.startswith("base."))
    assert all(p["nominal"] == nominal[p["name"]] for p in from_nominal["parameters"])
    missing = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs, "start_version": 9})
    assert missing.status_code == 422 and "start_version 9" in missing.json()["detail"]
    assert client.get(f"/v1/robots/{robot_id}/parameters").json()["version"] == 2  # nothing else changed
