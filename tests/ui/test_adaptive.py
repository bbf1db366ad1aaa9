"""An adaptive campaign in /ui (issue 46), driven by clicks on a UR5-like robot measured by a simulated tracker
whose truth only this test knows: started from the robot's page, each asked pose measured at the joints the page
showed (the first batch in the downloaded CSV, filled in and uploaded; a blunder of 0.5 mm pasted as JSON; the
rest pasted as CSV), the blunder shown flagged with the API's numbers, a reload resuming the campaign, done and
why, the chart's points and the steps' numbers equal the API's, and the finish opening the stored calibration.
The cell option appears only when the API's OpenAPI document declares `cell` on the create body."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from playwright.sync_api import expect

from harness.records import records
from models.description.examples import ur5_like
from models.simulation import perturbed_robot
from tests.ui.conftest import PAGE_WAIT_MS, screenshot, watched_page
from tests.ui.pages import posted_ur5, ready
from tests.ui.test_cell import CELL

pytestmark = pytest.mark.slow  # a browser against the live server of tests/ui

DESC = ur5_like()
TRUTH = perturbed_robot(DESC, seed=5)
BLUNDER_MM = 0.5
LAYOUT = ["q1", "q2", "q3", "q4", "q5", "q6", "x", "y", "z", "qw", "qx", "qy", "qz"]


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[Any]:
    yield from watched_page(browser, server, viewport={"width": 1400, "height": 1000})


def _rows(page: Any, selector: str) -> list[list[str]]:
    rows: list[list[str]] = page.eval_on_selector_all(
        f"{selector} tbody tr", "rows => rows.map(r => [...r.cells].map(c => c.textContent.trim()))"
    )
    return rows


def _shown(text: str) -> float:
    """A number as the page prints it (4 significant digits unless told), back to a float."""
    return float(text.split(maxsplit=1)[0])


def _measure(joints_deg: list[list[float]], seed: int, blunder: bool = False) -> list[dict[str, Any]]:
    """What the tracker reports at these joints (degrees), with noise; a blunder is 0.5 mm off along x."""
    out = records(DESC, TRUTH, np.array(joints_deg) / DESC.joint_to_boundary, seed)
    if blunder:
        position = out[0]["position"]
        assert isinstance(position, list)
        out[0]["position"] = [position[0] + BLUNDER_MM, *position[1:]]
    return out


def _as_csv(measured: list[dict[str, Any]]) -> str:
    rows = [[*r["joints"], *r["position"], *r["orientation"]] for r in measured]
    return "\n".join([",".join(LAYOUT), *(",".join(repr(float(v)) for v in row) for row in rows)]) + "\n"


def _next_shown(page: Any, campaign: dict[str, Any]) -> list[list[float]]:
    """The poses the page asks for, as printed (6 significant digits), checked against the API's `next`."""
    shown = [[float(c) for c in row[1:7]] for row in _rows(page, "#adaptive-next")]
    asked = [p["joints"] for p in campaign["next"]]
    assert np.allclose(shown, asked, rtol=1e-5, atol=1e-4)
    return shown


def _post(page: Any, text: str, steps: int) -> None:
    page.fill("#adaptive-records", text)
    page.click("#adaptive-post")
    expect(page.locator("#adaptive-state")).to_have_attribute("data-steps", str(steps), timeout=PAGE_WAIT_MS)


def _start(page: Any, server: str, robot_id: str) -> str:
    page.goto(f"{server}/ui#/robots/{robot_id}")
    ready(page, f"^#/robots/{robot_id}$")
    expect(page.locator("#adaptive-none")).to_have_text("No adaptive campaign yet.")
    page.click("#go-adaptive")
    ready(page, "/adaptive$")
    assert page.locator("#adaptive-cell").count() == 0  # the API declares no `cell` yet on this body
    page.fill("#adaptive-target", "0.05")
    page.fill("#adaptive-candidates", "100")
    page.fill("#adaptive-seed", "2")
    page.fill("#adaptive-budget", "40")
    with page.expect_request(lambda r: r.url.endswith("/adaptive-campaigns") and r.method == "POST") as sent:
        page.click("#adaptive-start")
    body = sent.value.post_data_json
    assert {k: body[k] for k in ("target_mm", "candidate_count", "seed", "budget", "measurement")} == {
        "target_mm": 0.05,
        "candidate_count": 100,
        "seed": 2,
        "budget": 40,
        "measurement": "pose",
    }
    ready(page, "/adaptive/[^/]+$")
    return page.evaluate("location.hash").rsplit("/", 1)[1]  # type: ignore[no-any-return]


def _first_batch_from_the_download(page: Any, server: str, path: str, tmp_path: Path) -> None:
    """The downloaded CSV is the calibration upload's layout with the measurements empty: posted so, the page
    names the empty cell; filled in and uploaded, it is the first step."""
    campaign = httpx.get(server + path).json()
    assert page.locator("#adaptive-measure h2").inner_text() == "Measure now: 7 poses"  # 36 parameters: 34 + 2
    page.click("#adaptive-copy")
    expect(page.locator("#adaptive-copied")).to_have_text("7 poses copied")
    with page.expect_download() as got:
        page.click("#adaptive-download")
    table = list(csv.reader(io.StringIO(Path(got.value.path()).read_text())))
    assert table[0] == LAYOUT and all(row[6:] == [""] * 7 for row in table[1:])
    joints = [[float(c) for c in row[:6]] for row in table[1:]]
    assert np.allclose(joints, [p["joints"] for p in campaign["next"]], atol=5e-7)
    page.set_input_files("#adaptive-file", got.value.path())  # posted as downloaded: nothing measured yet
    page.click("#adaptive-post")
    expect(page.locator("#adaptive-post-error")).to_have_text("line 2, column 7 (x): '' is not a number")
    assert httpx.get(f"{server}{path}").json()["steps"] == []  # nothing sent
    filled = tmp_path / "measured.csv"
    filled.write_text(_as_csv(_measure(joints, 1)))
    page.set_input_files("#adaptive-file", str(filled))
    expect(page.locator("#adaptive-records")).to_have_value(filled.read_text())
    page.click("#adaptive-post")
    expect(page.locator("#adaptive-state")).to_have_attribute("data-steps", "1", timeout=PAGE_WAIT_MS)


def _blunder_flagged(page: Any, server: str, path: str) -> dict[str, Any]:
    campaign = httpx.get(server + path).json()
    _post(page, json.dumps({"measurements": _measure(_next_shown(page, campaign), 2, blunder=True)}), 2)
    campaign = httpx.get(server + path).json()
    (blunder,) = campaign["steps"][1]["blunders"]
    assert blunder["record"] == 7 and campaign["excluded"] == [7]
    (row,) = _rows(page, "#adaptive-blunders")
    assert [int(row[0]), int(row[1])] == [8, 2]  # the 8th record posted, flagged at step 2
    for shown, key in zip(row[2:5], ("statistic", "threshold", "position_mm"), strict=True):
        assert _shown(shown) == pytest.approx(blunder[key], rel=5e-4)
    assert blunder["position_mm"] == pytest.approx(BLUNDER_MM, abs=0.1)
    assert "mm off the estimate of the other records" in row[5]
    assert _rows(page, "#adaptive-next")[0][-1] == "again: record 8 was a blunder"
    expect(page.locator("#adaptive-step-note")).to_contain_text("flagged as a blunder: record 8")
    screenshot(page, "adaptive-blunder")
    return dict(campaign)


def _numbers_equal_the_apis(page: Any, campaign: dict[str, Any]) -> None:
    """The steps' table, the chart's points and the summary print the API's numbers."""
    rows = _rows(page, "#adaptive-steps")
    assert [int(r[0]) for r in rows] == [s["number"] for s in campaign["steps"]]
    for row, step in zip(rows, campaign["steps"], strict=True):
        assert [int(row[1]), int(row[2])] == [step["posted"], step["records"]]
        assert _shown(row[3]) == pytest.approx(step["predicted"]["rms_tcp_mm"], rel=5e-4)
        assert _shown(row[4]) == pytest.approx(step["predicted"]["max_tcp_mm"], rel=5e-4)
    points = page.locator("#adaptive-plot circle.point.s0")
    assert points.count() == len(campaign["steps"])  # every step identified the robot (7 records to start)
    titles = [points.nth(k).locator("title").text_content() or "" for k in range(points.count())]
    values = [float(t.rsplit(": ", 1)[1]) for t in titles]
    assert values == pytest.approx([s["predicted"]["rms_tcp_mm"] for s in campaign["steps"]], rel=1e-5)
    assert page.locator("#adaptive-plot circle.point.s1").count() == len(campaign["steps"])  # the target line
    assert _shown(page.locator("#adaptive-predicted").inner_text()) == pytest.approx(
        campaign["predicted"]["rms_tcp_mm"], rel=5e-4
    )


def test_an_adaptive_campaign_measured_through_the_browser(page: Any, server: str, tmp_path: Path) -> None:
    robot_id = posted_ur5(server, "ur5-adaptive-ui")
    campaign_id = _start(page, server, robot_id)
    path = f"/v1/robots/{robot_id}/adaptive-campaigns/{campaign_id}"
    campaign = httpx.get(server + path).json()
    _next_shown(page, campaign)
    screenshot(page, "adaptive-start")
    _first_batch_from_the_download(page, server, path, tmp_path)
    campaign = _blunder_flagged(page, server, path)

    page.reload()  # the page is drawn from the API's stored campaign alone: a reload resumes it
    ready(page, f"/adaptive/{campaign_id}$")
    expect(page.locator("#adaptive-state")).to_have_attribute("data-steps", "2")
    assert [int(r[0]) for r in _rows(page, "#adaptive-blunders")] == [8]
    seed = 3
    while campaign["status"] == "measuring":
        _post(page, _as_csv(_measure(_next_shown(page, campaign), seed)), len(campaign["steps"]) + 1)
        campaign = httpx.get(server + path).json()
        seed += 1
        assert seed < 20, "the campaign should stop at its 0.05 mm target well before its budget"
    expect(page.locator("#adaptive-reason")).to_have_text(campaign["reason"])
    assert "reaches the target 0.05 mm" in campaign["reason"]
    assert page.locator("#adaptive-measure").count() == 0  # nothing more to measure
    _numbers_equal_the_apis(page, campaign)
    screenshot(page, "adaptive-done")

    page.click("#adaptive-finish")
    ready(page, "^#/calibrations/")
    finished = httpx.get(server + path).json()
    assert finished["status"] == "finished" and page.evaluate("location.hash") == (
        f"#/calibrations/{finished['calibration_id']}"
    )
    calibration = httpx.get(f"{server}/v1/calibrations/{finished['calibration_id']}").json()
    assert calibration["measurements"] == campaign["records"] - 1  # the blunder left out
    page.goto(f"{server}/ui#/robots/{robot_id}")
    ready(page, f"^#/robots/{robot_id}$")
    (listed,) = _rows(page, "#adaptive-campaigns")
    assert listed[1] == "finished" and listed[3] == f"{campaign['records']} / 40"
    assert _shown(listed[4]) == pytest.approx(campaign["predicted"]["rms_tcp_mm"], rel=5e-4)
    screenshot(page, "adaptive-robot")


def test_the_cell_option_follows_the_api_and_a_bad_target_is_refused(page: Any, server: str) -> None:
    """With the OpenAPI document declaring `cell` on the create body (routed here: the API may not yet), a robot
    with a cell gets the box, ticked, and its request carries `"cell": "stored"`; a bad target shows the API's
    refusal naming the field."""
    robot_id = posted_ur5(server, "ur5-adaptive-cell")
    page.goto(f"{server}/ui#/robots/{robot_id}/adaptive")
    ready(page, "/adaptive$")
    page.fill("#adaptive-target", "0")
    page.click("#adaptive-start")
    expect(page.locator("#adaptive-start-error")).to_contain_text("target_mm")
    assert httpx.get(f"{server}/v1/robots/{robot_id}/adaptive-campaigns").json() == []

    document = httpx.get(f"{server}/openapi.json").json()
    create = document["components"]["schemas"]["AdaptiveCampaignCreate"]["properties"]
    create.setdefault("cell", {"anyOf": [{"const": "stored", "type": "string"}, {"type": "null"}]})
    page.route("**/openapi.json", lambda route: route.fulfill(json=document))
    page.reload()
    ready(page, "/adaptive$")
    expect(page.locator("#adaptive-no-cell")).to_contain_text("This robot has no cell")
    assert httpx.put(f"{server}/v1/robots/{robot_id}/cell", json=CELL).status_code == 200
    page.reload()
    ready(page, "/adaptive$")
    expect(page.locator("#adaptive-cell")).to_be_checked()
    posted: list[dict[str, Any]] = []

    def refuse(route: Any) -> None:  # the request is what is checked here, not a campaign
        posted.append(route.request.post_data_json)
        route.fulfill(status=422, json={"status": 422, "detail": "routed by the test"})

    page.route("**/adaptive-campaigns", refuse)
    page.click("#adaptive-start")
    expect(page.locator("#adaptive-start-error")).to_contain_text("routed by the test")
    assert posted[0]["cell"] == "stored"
    screenshot(page, "adaptive-start-cell")
