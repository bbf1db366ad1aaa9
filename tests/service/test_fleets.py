"""Fleets over HTTP: the population of a structure's calibrated robots, calibrations with its prior, the report's
comparison, and the refusals (too few units, another fleet, reference records)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import sample_workspace
from models.description.examples import iiwa_like_document, ur5_like, ur5_like_document
from models.evaluation.fleet import MIN_UNITS
from models.simulation import fleet_unit
from service.reports.calibration import FLEET_HEADER, CalibrationReport
from tests.service.helpers import records

DESC = ur5_like()
ROOT = Path(__file__).resolve().parents[2]


def _robot(client: TestClient, name: str, document: dict[str, Any] | None = None) -> str:
    made = client.post("/v1/robots", json={"name": name, "structure": document or ur5_like_document()})
    assert made.status_code == 201, made.text
    return str(made.json()["id"])


def _calibrate(client: TestClient, robot_id: str, unit: int, poses: int, fleet_seed: int = 0, **options: object) -> Any:
    joints = sample_workspace(DESC, poses, seed=300 + unit)
    truth = fleet_unit(DESC, unit, fleet_seed=fleet_seed, spread=0.02)
    body: dict[str, object] = {"measurements": records(DESC, truth, joints, seed=400 + unit)}
    if options:
        body["options"] = options
    return client.post(f"/v1/robots/{robot_id}/calibrations", json=body)


@pytest.mark.slow  # a robot of a structure the session's registry may not have built yet: 0.2-1 s here
def test_a_fleet_of_one_is_refused_with_how_many_it_has_and_needs(client: TestClient) -> None:
    robot = _robot(client, "alone")
    fleet = client.get(f"/v1/robots/{robot}/fleet").json()
    assert fleet["calibrated"] == 0 and fleet["needed"] == MIN_UNITS and not fleet["ready"]
    assert [u["robot_id"] for u in fleet["units"]] == [robot] and fleet["parameters"] == []
    refused = _calibrate(client, robot, 0, 8, prior="fleet")
    assert refused.status_code == 422
    problem = refused.json()
    assert problem["type"].endswith("/fleet-too-small")
    assert problem["units"] == 0 and problem["needed"] == MIN_UNITS
    assert f"calibrate {MIN_UNITS} more units" in problem["detail"]
    # a ballbar's records take no prior (their references are fitted with the robot): said before anything else
    ballbar = [
        {"kind": "distance", "joints": [0.0, -90.0, 90.0, 0.0, 45.0, 10.0 * k], "anchor": "a1", "distance_mm": 300.0}
        for k in range(12)
    ]
    refused = client.post(
        f"/v1/robots/{robot}/calibrations", json={"measurements": ballbar, "options": {"prior": "fleet"}}
    )
    assert refused.status_code == 422 and refused.json()["field"] == "options.prior", refused.text
    # nothing was stored
    assert client.get(f"/v1/robots/{robot}/calibrations").json() == []
    design = client.post(f"/v1/robots/{robot}/pose-designs", json={"count": 8, "candidate_count": 50, "prior": "fleet"})
    assert design.status_code == 422 and design.json()["type"].endswith("/fleet-too-small")
    # a fleet by its key; an unknown one is not found
    assert client.get(f"/v1/fleets/{fleet['fleet']}").json() == fleet
    assert client.get("/v1/fleets/0123456789abcdef").status_code == 404
    assert client.get("/v1/fleets/not-a-key").status_code == 422


@pytest.mark.slow  # six calibrations over HTTP: ~1.5 s
def test_a_fleet_calibrates_a_new_unit_with_its_prior(client: TestClient) -> None:
    """Five calibrated units make a population; a sixth is calibrated from 6 poses with it, its report compares
    it with the others; a robot of another structure is its own fleet, and naming this fleet for it is refused."""
    units = [_robot(client, f"ur5-{k}") for k in range(MIN_UNITS + 2)]
    for k, robot in enumerate(units[:MIN_UNITS]):
        done = _calibrate(client, robot, k, 40)
        assert done.status_code == 201 and done.json()["applied"], done.text
    fleet = client.get(f"/v1/robots/{units[0]}/fleet").json()
    assert fleet["ready"] and fleet["calibrated"] == MIN_UNITS and fleet["outliers"] == []
    assert client.get(f"/v1/fleets/{fleet['fleet']}").json() == fleet
    names = {p["name"] for p in fleet["parameters"]}
    assert "link2.a" in names and not any(n.startswith("base.") for n in names)
    # the population holds the fleet's common deviation: link2.a's mean offset is the simulated one
    truth = fleet_unit(DESC, 0, spread=0.0).truth
    i = DESC.parameters.index["link2.a"]
    link2 = next(p for p in fleet["parameters"] if p["name"] == "link2.a")
    assert abs(link2["mean_offset"] - (truth[i] - DESC.parameters.nominal[i])) < 3 * link2["spread"]

    # the target mode counts the poses a calibration with the prior needs
    target = {"target": {"rms_tcp_mm": 0.04}, "criterion": "I", "candidate_count": 100}
    counted = [
        client.post(f"/v1/robots/{units[MIN_UNITS]}/pose-designs", json={**target, "prior": p}).json()
        for p in ("none", "fleet")
    ]
    assert 0 < counted[1]["count"] < counted[0]["count"], counted

    new = units[MIN_UNITS]
    with_prior = _calibrate(client, new, 50, 6, prior="fleet", fleet=fleet["fleet"])
    assert with_prior.status_code == 201, with_prior.text
    report = with_prior.json()
    assert report["fleet"]["prior_used"] and report["fleet"]["units"] == MIN_UNITS
    assert report["fleet"]["fleet"] == fleet["fleet"] and not report["fleet"]["outlier"]
    assert {p["name"] for p in report["fleet"]["parameters"]} <= names
    assert report["applied"], report["not_applied_reason"]
    # the HTML and PDF reports' section (its rows; rendering the page's figures is test_reports')
    shown = CalibrationReport(report, "ur5-new")
    assert "calibrated with the fleet's prior" in shown.fleet_line() and "like the others" in shown.fleet_line()
    rows = shown.fleet_rows()
    assert len(rows) == len(report["fleet"]["parameters"]) and all(len(r) == len(FLEET_HEADER) for r in rows)
    assert abs(rows[0][5]) == max(abs(p["z"]) for p in report["fleet"]["parameters"])
    # a unit calibrated with the prior does not vote in its own fleet's population
    after = client.get(f"/v1/robots/{new}/fleet").json()
    assert after["calibrated"] == MIN_UNITS
    assert next(u for u in after["units"] if u["robot_id"] == new)["calibrated"] is False

    plain = _calibrate(client, units[-1], 51, 20).json()
    assert plain["fleet"]["prior_used"] is False and plain["fleet"]["units"] == MIN_UNITS
    again = _calibrate(client, units[0], 0, 20).json()  # itself left out of the population it is compared with
    assert again["fleet"]["units"] == MIN_UNITS

    # a unit of another make (its own systematic deviations): its report and the fleet say it is not like the others
    odd = _robot(client, "ur5-odd")
    stranger = _calibrate(client, odd, 60, 40, fleet_seed=7).json()
    assert stranger["applied"] and stranger["fleet"]["outlier"]
    assert any(p["flagged"] for p in stranger["fleet"]["parameters"])
    assert client.get(f"/v1/robots/{odd}/fleet").json()["outliers"] == [odd]

    assert np.isfinite(report["predicted_accuracy"]["rms_position_mm"])
    _other_fleets_are_refused(client, fleet["fleet"])


def _other_fleets_are_refused(client: TestClient, key: str) -> None:
    """A robot of another structure is of another fleet: naming this one for it is refused; the IWR (a campaign
    file, the prior asked in the query) is a fleet of its own, with no calibrated unit yet."""
    other = _robot(client, "iiwa", iiwa_like_document())
    mismatch = client.post(
        f"/v1/robots/{other}/calibrations",
        json={
            "measurements": [{"joints": [0.0] * 7, "position": [0.0, 0.0, 0.0]}] * 10,
            "options": {"prior": "fleet", "fleet": key},
        },
    )
    assert mismatch.status_code == 422 and mismatch.json()["type"].endswith("/prior-mismatch")
    assert key in mismatch.json()["detail"] and mismatch.json()["got"] == key
    assert client.get(f"/v1/robots/{other}/fleet").json()["fleet"] != key
    iwr = client.post("/v1/robots", json={"name": "cell"}).json()["id"]
    csv = client.post(
        f"/v1/robots/{iwr}/calibrations?prior=fleet",
        content=(ROOT / "examples" / "campaign.csv").read_bytes(),
        headers={"Content-Type": "text/csv"},
    )
    assert csv.status_code == 422 and csv.json()["type"].endswith("/fleet-too-small")
    assert client.get(f"/v1/robots/{iwr}/fleet").json()["fleet"] != key
