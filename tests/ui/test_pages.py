"""/ui in a real browser: every page loads with no console error and no request outside the service, the plots
draw one mark per datum, the report shows the API's numbers, and a screenshot of each page is kept (with
IWR_UI_SCREENSHOTS=1)."""

from __future__ import annotations

import re
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import httpx
import numpy as np
import pytest
from playwright.sync_api import expect

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from tests.service.helpers import records
from tests.ui.conftest import PAGE_WAIT_MS, PageProblems, screenshot

pytestmark = pytest.mark.slow  # a live server, two calibrations and a browser: ~13 s here
DESC = iwr()
DESIGN_COUNT = 12


@pytest.fixture(scope="module")
def data(server: str) -> dict[str, Any]:
    """A robot with two calibrations, a restore (four versions), a pose design and a validation."""
    with httpx.Client(base_url=server, timeout=60) as http:
        # A name of its own each time: a worker may run this module twice (pytest-xdist's work stealing) against
        # its one session server, where names are unique.
        robot = http.post("/v1/robots", json={"name": f"cell-ui-{uuid.uuid4().hex[:8]}"}).json()
        sim = perturbed_robot(DESC, seed=121)
        calibrations = []
        for seed in (122, 125):
            recs = records(DESC, sim, sample_workspace(DESC, 40, seed=seed), seed=seed + 1)
            answer = http.post(f"/v1/robots/{robot['id']}/calibrations", json={"measurements": recs})
            assert answer.status_code == 201, answer.text
            calibrations.append(answer.json())
        assert http.post(f"/v1/robots/{robot['id']}/parameter-versions/2/restore").status_code == 201
        design = http.post(
            f"/v1/robots/{robot['id']}/pose-designs",
            json={"count": DESIGN_COUNT, "criterion": "D", "candidate_count": 80, "seed": 1},
        ).json()
        repeated = np.repeat(sample_workspace(DESC, 2, seed=130), 3, axis=0)
        validation = http.post(
            f"/v1/robots/{robot['id']}/validations",
            json={"measurements": records(DESC, sim, repeated, seed=131), "versions": [1, 4], "register": True},
        ).json()
        versions = http.get(f"/v1/robots/{robot['id']}/parameter-versions").json()
    return {
        "robot": robot,
        "calibrations": calibrations,
        "design": design,
        "versions": versions,
        "validation": validation,
    }


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[tuple[Any, PageProblems, set[str]]]:
    page = browser.new_page(viewport={"width": 1200, "height": 900})
    problems = PageProblems(page)
    hosts: set[str] = set()
    page.on("request", lambda r: hosts.add(urlparse(r.url).netloc))
    yield page, problems, hosts
    assert hosts <= {urlparse(server).netloc, ""}, f"fetched from elsewhere: {hosts}"
    assert problems.messages == []
    page.close()


def _open(page: Any, server: str, fragment: str) -> None:
    page.goto(f"{server}/ui{fragment}")
    # Attribute waits, not wait_for_function: the page's Content-Security-Policy forbids eval, which that uses.
    expect(page.locator("body")).to_have_attribute("data-ready", fragment or "#/", timeout=PAGE_WAIT_MS)


@pytest.mark.usefixtures("data")
def test_robots_page(page: tuple[Any, PageProblems, set[str]], server: str, data: dict[str, Any]) -> None:
    p, _, _ = page
    _open(p, server, "#/")
    listed = httpx.get(f"{server}/v1/robots").json()  # the server is shared: other UI tests add robots
    assert p.locator("#robots tbody tr").count() == len(listed)
    assert data["robot"]["name"] in p.locator("#robots a").all_inner_texts()
    screenshot(p, "robots")


def test_robot_page_history_drift_and_design(
    page: tuple[Any, PageProblems, set[str]], server: str, data: dict[str, Any]
) -> None:
    p, _, _ = page
    robot_id = data["robot"]["id"]
    _open(p, server, f"#/robots/{robot_id}")
    assert p.locator("#calibrations tbody tr").count() == 2
    assert p.locator("#versions tbody tr").count() == len(data["versions"]) == 4
    assert p.locator("#validations tbody tr").count() == 2  # one validation, two versions
    rms = [r["position_mm"]["rms"] for r in data["validation"]["results"]]
    cells = p.locator("#validations tbody tr td:nth-child(4)").all_inner_texts()
    assert [float(c) for c in cells] == pytest.approx(rms, rel=1e-3)  # shown to 4 digits
    # One point per version on the drift plot, one error bar per version with a std error (the calibrated ones).
    assert p.locator("#drift-plot circle.point").count() == 4
    assert p.locator("#drift-plot line.band").count() == 3
    # Accuracy over time: one event per calibration, each with its measured (RMS after) and predicted accuracy.
    history = httpx.get(f"{server}/v1/robots/{robot_id}/history").json()
    assert p.locator("#history-events tbody tr").count() == len(history) == 2
    assert p.locator("#history-plot circle.point.s0").count() == 2
    assert p.locator("#history-plot circle.point.s1").count() == 2
    shown = p.locator("#history-events tbody tr td:nth-child(5)").all_inner_texts()
    expected = [c["residuals"]["after"]["rms_mm"] for c in data["calibrations"]]
    assert [float(c) for c in shown] == pytest.approx(expected, rel=1e-3)
    with p.expect_download() as exported:
        p.click("#history-csv")
    lines = Path(exported.value.path()).read_text().splitlines()
    assert lines[0].startswith("at,kind,id,version,outcome,rms_mm") and len(lines) == 3
    screenshot(p, "robot-history")
    p.select_option("#drift-parameter", "base.x")
    expect(p.locator("#drift-plot title").first).to_have_text(re.compile(r"^base\.x"))
    assert p.locator("#drift-plot circle.point").count() == 4
    p.locator("#designs a", has_text="draw").click()
    p.wait_for_selector("#design-side")
    assert p.locator("#design-top circle.point").count() == DESIGN_COUNT
    assert p.locator("#design-side circle.point").count() == DESIGN_COUNT
    screenshot(p, "robot")


def test_report_page_shows_the_api_numbers(
    page: tuple[Any, PageProblems, set[str]], server: str, data: dict[str, Any]
) -> None:
    p, _, _ = page
    calibration = data["calibrations"][0]
    _open(p, server, f"#/calibrations/{calibration['id']}/report")
    frame = p.frame_locator("#report")
    frame.locator("figure#fig-correlation svg").wait_for()
    shown = {
        key: frame.locator(f'[data-key="{key}"]').get_attribute("data-value")
        for key in ("residuals.after.rms_mm", "residuals.before.rms_mm", "variance_factor", "rank")
    }
    assert float(shown["residuals.after.rms_mm"]) == calibration["residuals"]["after"]["rms_mm"]
    assert float(shown["residuals.before.rms_mm"]) == calibration["residuals"]["before"]["rms_mm"]
    assert float(shown["variance_factor"]) == calibration["variance_factor"]
    assert int(shown["rank"]) == calibration["rank"]
    assert frame.locator("figure svg").count() >= 6
    # Real plots: the residual bars are one drawn path per pose at least.
    assert frame.locator("figure#fig-residual-bars svg path").count() > calibration["measurements"]
    screenshot(p, "report")


@pytest.mark.usefixtures("data")
def test_jobs_page(page: tuple[Any, PageProblems, set[str]], server: str) -> None:
    p, _, _ = page
    listed = httpx.get(f"{server}/openapi.json").json()["paths"].get("/v1/jobs", {}).get("get")
    _open(p, server, "#/jobs")
    screenshot(p, "jobs")
    if listed is None:
        # The page says so instead of failing; the progress table comes with GET /v1/jobs (the jobs branch).
        assert p.locator("#no-job-list").count() == 1
        pytest.skip("this service has no GET /v1/jobs yet: the page shows its note")
    assert p.locator("#jobs, p.muted").count() >= 1


def _shown(row: Any) -> list[str]:
    return [str(c) for c in row.locator("td").all_inner_texts()]


def test_version_diff_by_clicks(page: tuple[Any, PageProblems, set[str]], server: str, data: dict[str, Any]) -> None:
    """Versions 2 and 3 (the two calibrations) ticked and compared: the rows that moved, sorted by |difference/σ|,
    the geometry apart from the registration, each number the API's."""
    p, _, _ = page
    robot_id = data["robot"]["id"]
    _open(p, server, f"#/robots/{robot_id}")
    compare = p.get_by_role("button", name="Compare the two ticked versions")
    assert compare.is_disabled()
    p.get_by_label("compare version 3").check()  # ticked newest first: the page still diffs the older against it
    p.get_by_label("compare version 2").check()
    compare.click()
    p.wait_for_selector("#diff-geometry")
    diff = httpx.get(f"{server}/v1/robots/{robot_id}/parameter-versions/2/diff/3").json()
    assert p.locator("#diff").get_attribute("data-a") == "2" and p.locator("#diff").get_attribute("data-b") == "3"
    shown_max = p.locator('[data-key="geometry_max_abs_sigma"]').get_attribute("data-value")
    assert float(shown_max) == diff["geometry_max_abs_sigma"]
    changed = [q for q in diff["parameters"] if q["name"] in set(diff["changed"])]
    for registration, table_id in ((False, "#diff-geometry"), (True, "#diff-registration")):
        expected = sorted(
            (q for q in changed if q["registration"] is registration), key=lambda q: -abs(q["difference_sigma"])
        )
        rows = p.locator(f"{table_id} tbody tr")
        assert rows.count() == len(expected) > 0
        for k in (0, 1, len(expected) - 1):  # the first two and the last, cell by cell
            name, a, b, difference, sigma, ratio, unit, *_ = _shown(rows.nth(k))
            q = expected[k]
            assert (name, unit) == (q["name"], q["unit"])
            assert [float(a), float(b)] == pytest.approx([q["a"], q["b"]], rel=1e-5, abs=1e-9)
            assert float(difference) == pytest.approx(q["difference"], rel=1e-2)
            assert float(sigma) == pytest.approx(q["std_error"], rel=1e-1)
            assert float(ratio) == pytest.approx(q["difference_sigma"], rel=1e-2)
        names = [str(n) for n in rows.locator("td:first-child").all_inner_texts()]
        assert names == [q["name"] for q in expected]
        assert all(n.startswith("base.") is registration for n in names)
    # The geometry's largest |difference/σ| is its table's first row.
    assert abs(float(_shown(p.locator("#diff-geometry tbody tr").first)[5])) == pytest.approx(
        diff["geometry_max_abs_sigma"], rel=1e-2
    )
    screenshot(p, "version-diff")
