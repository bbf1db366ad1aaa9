"""A robot's fleet in /ui: a calibration (and a pose design) with the fleet's prior refused in words while the fleet
is too small, and the fleet section's numbers (units, calibrated, needed, the outlier unit, the population) equal
to the API's.
The robots are UR5-like with a real UR5's ±360° joint ranges (`FLEET_DOCUMENT`), a structure no other UI test uses, so
the fleet is this test's own on the shared server: the other UI tests' UR5-like robots (±180°) are another fleet, and
they may run before it on the same server."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import expect

from models import sample_workspace
from models.description.examples import ur5_like, ur5_like_document
from models.evaluation.fleet import MIN_UNITS
from models.simulation import fleet_unit
from tests.service.helpers import records
from tests.ui.conftest import PageProblems, screenshot

pytestmark = pytest.mark.slow  # a structure the live server compiles first (~9 s), six calibrations (~1 s)
DESC = ur5_like()


def _fleet_document() -> dict[str, Any]:
    """ur5_like_document() with every joint's range ±360° (a real UR5's): the same kinematics, another fleet key
    (a fleet is one structure document; the ranges are part of it). The records, drawn within ±180°, fit both."""
    document = ur5_like_document()
    for link in document["stages"][0]["links"]:
        link["range"] = [-360.0, 360.0]
    return document


FLEET_DOCUMENT = _fleet_document()


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    problems = PageProblems(page)
    yield page
    assert problems.messages == []
    page.close()


def _ready(page: Any, fragment: str) -> None:
    # Attribute waits, not wait_for_function: the page's Content-Security-Policy forbids eval, which that uses.
    expect(page.locator("body")).to_have_attribute("data-ready", fragment, timeout=30_000)


def _unit_records(unit: int, poses: int, fleet_seed: int = 0) -> list[dict[str, object]]:
    """Unit `unit` of a simulated fleet (a shared deviation, each unit 2 % of a tolerance of its own), as in
    tests/service/test_fleets.py: five such units and one of another make (fleet_seed 7) flag that one."""
    truth = fleet_unit(DESC, unit, fleet_seed=fleet_seed, spread=0.02)
    return records(DESC, truth, sample_workspace(DESC, poses, seed=300 + unit), seed=400 + unit)


def _campaign_csv(path: Path, recs: list[dict[str, Any]]) -> Path:
    with path.open("w", newline="") as f:
        out = csv.writer(f)
        out.writerow([f"q{k + 1}" for k in range(6)] + ["x", "y", "z", "qw", "qx", "qy", "qz"])
        for r in recs:
            out.writerow([*r["joints"], *r["position"], *r["orientation"]])
    return path


def test_fleet_prior_refused_then_the_fleet_section(page: Any, server: str, tmp_path: Path) -> None:
    with httpx.Client(base_url=server, timeout=120) as http:
        made = [http.post("/v1/robots", json={"name": f"ur5-fleet-{k}", "structure": FLEET_DOCUMENT}) for k in range(6)]
        assert all(m.status_code == 201 for m in made), [m.text for m in made]
        units = [m.json()["id"] for m in made]

        # No calibrated unit yet: the prior asked for in the form is refused, with the counts said in words.
        page.goto(f"{server}/ui#/robots/{units[0]}/calibrate")
        _ready(page, f"#/robots/{units[0]}/calibrate")
        assert f"a prior needs {MIN_UNITS}" in page.locator("#fleet-prior-note").inner_text()
        page.set_input_files("#campaign-file", str(_campaign_csv(tmp_path / "unit0.csv", _unit_records(0, 12))))
        page.wait_for_selector("#preview-table")
        page.get_by_label("Calibrate with the fleet's prior").check()
        page.get_by_role("button", name="Calibrate", exact=True).click()
        page.locator("#fleet-too-small").wait_for(timeout=60_000)
        job = http.get("/v1/jobs", params={"robot_id": units[0]}).json()[0]
        problem = job["error"]
        assert job["status"] == "failed" and problem["type"].endswith("/fleet-too-small")
        assert (problem["units"], problem["needed"]) == (0, MIN_UNITS)
        refusal = page.locator("#calibration-refused").inner_text()
        assert problem["detail"] in refusal
        said = page.locator("#fleet-too-small").inner_text()
        assert f"has 0 other calibrated units; its prior needs {MIN_UNITS}" in said
        assert f"Calibrate {MIN_UNITS} more robots" in said
        assert http.get(f"/v1/robots/{units[0]}/calibrations").json() == []  # nothing stored
        screenshot(page, "fleet-too-small")
        # A pose design for that calibration: the same refusal.
        page.goto(f"{server}/ui#/robots/{units[0]}/design")
        _ready(page, f"#/robots/{units[0]}/design")
        page.get_by_label("Poses", exact=True).fill("8")
        page.get_by_label("Candidate poses sampled").fill("50")
        page.get_by_label("Design for a calibration with the fleet's prior").check()
        page.get_by_role("button", name="Design the poses").click()
        page.locator("#design-message #fleet-too-small").wait_for(timeout=30_000)
        assert problem["detail"] in page.locator("#design-error").inner_text()
        assert http.get(f"/v1/robots/{units[0]}/pose-designs").json() == []

        # Five units and one of another make calibrated without a prior: the fleet is ready, that one an outlier.
        for k, robot in enumerate(units[:MIN_UNITS]):
            done = http.post(f"/v1/robots/{robot}/calibrations", json={"measurements": _unit_records(k, 40)})
            assert done.status_code == 201 and done.json()["applied"], done.text
        odd = units[MIN_UNITS]
        done = http.post(f"/v1/robots/{odd}/calibrations", json={"measurements": _unit_records(60, 40, fleet_seed=7)})
        assert done.status_code == 201, done.text
        fleet = http.get(f"/v1/robots/{odd}/fleet").json()
    assert fleet["ready"] and fleet["outliers"] == [odd]  # the premise of what follows

    _fleet_section_is_the_apis(page, server, fleet, odd)


def _fleet_section_is_the_apis(page: Any, server: str, fleet: dict[str, Any], odd: str) -> None:
    page.goto(f"{server}/ui#/robots/{odd}")
    _ready(page, f"#/robots/{odd}")
    shown = {
        key: float(page.locator(f'#fleet [data-key="{key}"]').get_attribute("data-value"))
        for key in ("units", "calibrated", "needed", "outliers", "prior_units")
    }
    assert shown == {
        "units": len(fleet["units"]),
        "calibrated": fleet["calibrated"],
        "needed": fleet["needed"],
        "outliers": 1,
        "prior_units": MIN_UNITS,  # the odd unit itself is never part of its own prior
    }
    assert page.locator("#fleet").get_attribute("data-fleet") == fleet["fleet"]
    assert page.locator("#fleet-prior").inner_text().startswith("A prior is available: 5 other calibrated units")
    rows = page.locator("#fleet-units tbody tr")
    assert rows.count() == len(fleet["units"])
    for k, unit in enumerate(fleet["units"]):
        cells = rows.nth(k).locator("td").all_inner_texts()
        assert cells[0] == unit["name"] and cells[2] == ("yes" if unit["calibrated"] else "no")
        assert cells[3] == {True: "outlier", False: "like the others", None: "—"}[unit["outlier"]]
        if unit["worst_z"] is not None:
            assert cells[4] == unit["worst_parameter"]
            assert float(cells[5]) == pytest.approx(unit["worst_z"], rel=1e-2)
    assert page.locator("#fleet-units td.status-failed").count() == 1
    population = page.locator("#fleet-population tbody tr")
    assert population.count() == len(fleet["parameters"]) > 0
    first = population.first.locator("td").all_text_contents()  # in a closed <details>: no rendered text
    p = fleet["parameters"][0]
    assert first[0] == p["name"] and first[4] == p["unit"]
    assert [float(first[1]), float(first[2])] == pytest.approx([p["mean_offset"], p["spread"]], rel=1e-2)
    screenshot(page, "fleet")
