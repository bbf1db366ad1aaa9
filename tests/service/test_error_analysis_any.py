"""POST /v1/error-analysis on any robot's description: the IWR's answer unchanged, a 7R arm's and a hexapod's
from their structure documents, magnitudes by parameter kind."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models.description.examples import hexapod_alone_document, iiwa_like, iiwa_like_document
from models.error_analysis import ErrorMagnitudes, error_analysis
from service.conversions.error_analysis import report_out

SMALL = {"poses": 12, "draws": 30, "seed": 4}
ZERO = {"leg_offset_mm": 0.0, "joint_position_mm": 0.0, "dh_angle_deg": 0.0, "dh_length_mm": 0.0}


def _study(client: TestClient, **body: Any) -> dict[str, Any]:
    answer = client.post("/v1/error-analysis", json={**SMALL, **body})
    assert answer.status_code == 200, answer.text
    result: dict[str, Any] = answer.json()
    return result


def _rms(case: dict[str, Any], model: str = "exact") -> float:
    return float(case[model]["position"]["absolute"]["rms_mm"])


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_iwr_study_is_unchanged_by_naming_an_iwr_robot(client: TestClient, robot_id: str) -> None:
    plain, named = _study(client), _study(client, robot_id=robot_id)
    for answer in (plain, named):
        answer.pop("seconds")
        answer.pop("robot")
    assert named == plain
    # and the thesis's figures are those of the study itself, on the nominal IWR
    assert plain["subsystems"]["whole"]["exact"]["position"]["absolute"]["rms_mm"] > 0.1


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_7r_arm_from_its_description(client: TestClient) -> None:
    arm = client.post("/v1/robots", json={"name": "arm-tolerances", "structure": iiwa_like_document()}).json()
    whole = _study(client, robot_id=arm["id"])
    # The study of the arm's nominal description, reported exactly as the library computes it.
    direct = report_out(error_analysis(iiwa_like(), n_poses=12, n_draws=30, seed=4, tolerances=ErrorMagnitudes()))
    expected = direct.model_dump(mode="json")
    for answer in (whole, expected):
        answer.pop("seconds")
        answer.pop("robot")
    assert whole == expected
    # No hexapod: the links are the whole robot, the hexapod case is exactly zero.
    subsystems = whole["subsystems"]
    assert _rms(subsystems["hexapod"]) == 0.0
    assert _rms(subsystems["carriage"]) == _rms(subsystems["whole"]) > 0.0
    # Magnitudes by kind: leg tolerances move nothing on an arm; the first-order model is linear in the link
    # tolerances (twice the lengths and angles: twice the error), the exact one nearly so.
    legs_only = _study(client, robot_id=arm["id"], **{**ZERO, "leg_offset_mm": 1.0, "joint_position_mm": 1.0})
    assert _rms(legs_only["subsystems"]["whole"]) == 0.0
    base = _study(client, robot_id=arm["id"], **{**ZERO, "dh_angle_deg": 0.05, "dh_length_mm": 0.2})
    double = _study(client, robot_id=arm["id"], **{**ZERO, "dh_angle_deg": 0.1, "dh_length_mm": 0.4})
    first, second = base["subsystems"]["whole"], double["subsystems"]["whole"]
    np.testing.assert_allclose(_rms(second, "first_order"), 2 * _rms(first, "first_order"), rtol=1e-9)
    np.testing.assert_allclose(_rms(second), 2 * _rms(first), rtol=1e-2)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_hexapod_alone_and_an_unknown_robot(client: TestClient) -> None:
    hexapod = client.post("/v1/robots", json={"name": "hex-tolerances", "structure": hexapod_alone_document()}).json()
    answer = _study(client, robot_id=hexapod["id"])
    subsystems = answer["subsystems"]
    # No links; the unperturbed hexapod's forward kinematics (Newton) returns its nominal pose to round-off.
    assert _rms(subsystems["carriage"]) < 1e-9
    np.testing.assert_allclose(_rms(subsystems["hexapod"]), _rms(subsystems["whole"]), rtol=1e-9)
    assert _rms(subsystems["whole"]) > 0.01
    # link tolerances move nothing on a hexapod alone
    links_only = _study(client, robot_id=hexapod["id"], **{**ZERO, "dh_angle_deg": 1.0, "dh_length_mm": 1.0})
    assert _rms(links_only["subsystems"]["whole"]) < 1e-9
    missing = client.post("/v1/error-analysis", json={**SMALL, "robot_id": "no-such-robot"})
    assert missing.status_code == 404
