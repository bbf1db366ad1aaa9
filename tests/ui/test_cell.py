"""A robot's cell in /ui (issue 46): a cell document uploaded for a UR5-like robot by the page (PUT with If-Match),
a bad one's problem shown naming its fields as the API does; the cell drawn from above, the side and the front,
each obstacle's outline and each link's capsule measured back from the SVG (its mapping in mm) against the
cell document's numbers and the API's forward kinematics frames; three poses checked with the API's verdicts;
the cell ended by two clicks; and a pose design in the cell whose refused counts and drawn TCPs are the API's."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from playwright.sync_api import expect
from scipy.spatial.transform import Rotation

from tests.service.test_cells_api import FIXTURE, TABLE, TRACKER
from tests.ui.conftest import PAGE_WAIT_MS, screenshot, watched_page
from tests.ui.pages import posted_ur5, ready, to_mm, view_mapping

pytestmark = pytest.mark.slow  # a browser against the live server of tests/ui

COLUMN: dict[str, Any] = {
    "name": "column",
    "kind": "cylinder",
    "radius_mm": 80,
    "length_mm": 900,
    "position_mm": [-600, -500, 450],
}
GLOBE: dict[str, Any] = {"name": "globe", "kind": "sphere", "radius_mm": 120, "position_mm": [300, -700, 500]}
# The service tests' cell (tests/service/test_cells_api.py) with a cylinder and a sphere: every kind drawn.
CELL: dict[str, Any] = {"obstacles": [TABLE, FIXTURE, COLUMN, GLOBE], "tracker": TRACKER}
VIEWS = {"cell-top": (0, 1), "cell-side": (0, 2), "cell-front": (1, 2)}


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[Any]:
    yield from watched_page(browser, server, viewport={"width": 1400, "height": 1000})


def _outline(page: Any, selector: str, m: dict[str, float]) -> np.ndarray:
    text: str = page.get_attribute(selector, "points")
    return np.array([to_mm(m, *map(float, p.split(","))) for p in text.split()])


def _box_corners(doc: dict[str, Any]) -> np.ndarray:
    """The 8 corners of a box obstacle in the world, from its document alone (scipy's rotation vector)."""
    half = np.array(doc["size_mm"]) / 2
    local = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    turn = Rotation.from_rotvec(np.radians(doc.get("rotation_vector_deg", [0, 0, 0])))
    return np.asarray(turn.apply(local) + np.array(doc["position_mm"]))


def _obstacles_drawn(page: Any, cell: dict[str, Any]) -> None:
    """Each obstacle in each view: a box's outline spans its corners' projection (the fixture's top view is its
    four turned corners), the cylinder's its radius and length, the sphere a circle of its radius."""
    for view, (u, v) in VIEWS.items():
        m = view_mapping(page, view)
        for doc in cell["obstacles"][:2]:
            drawn = _outline(page, f"#{view} polygon.obstacle[data-name={doc['name']}]", m)
            corners = _box_corners(doc)[:, [u, v]]
            assert drawn.min(axis=0) == pytest.approx(corners.min(axis=0), abs=1e-6)
            assert drawn.max(axis=0) == pytest.approx(corners.max(axis=0), abs=1e-6)
        fixture_top = _outline(page, "#cell-top polygon.obstacle[data-name=fixture]", view_mapping(page, "cell-top"))
        assert len(fixture_top) == 4
        assert sorted(map(tuple, fixture_top.round(6))) == sorted(
            {tuple(c) for c in _box_corners(FIXTURE)[:, :2].round(6)}
        )
        column = _outline(page, f"#{view} polygon.obstacle[data-name=column]", m)
        half = [COLUMN["radius_mm"], COLUMN["radius_mm"], COLUMN["length_mm"] / 2]
        centre = np.array(COLUMN["position_mm"])
        assert column.min(axis=0) == pytest.approx((centre - half)[[u, v]], abs=1e-6)
        assert column.max(axis=0) == pytest.approx((centre + half)[[u, v]], abs=1e-6)
        globe = page.locator(f"#{view} circle.obstacle[data-name=globe]")
        cx, cy, r = (float(globe.get_attribute(a) or "nan") for a in ("cx", "cy", "r"))
        assert to_mm(m, cx, cy) == pytest.approx(tuple(np.array(GLOBE["position_mm"])[[u, v]]), abs=1e-6)
        assert r / m["scale"] == pytest.approx(GLOBE["radius_mm"])


def _robot_drawn(page: Any, server: str, robot_id: str) -> None:
    """Each of the robot's shapes (GET …/cell's geometry) as a round-capped line between its frames' origins where
    the forward kinematics' frames put them at the drawn joints, as wide as the capsule; the tracker and its range."""
    stored = httpx.get(f"{server}/v1/robots/{robot_id}/cell").json()
    joints = [float(v) for v in page.get_attribute("#cell-views", "data-pose").strip("[]").split(",")]
    fk = httpx.post(f"{server}/v1/robots/{robot_id}/forward-kinematics", json={"joints": [joints], "frames": True})
    frames = fk.json()["frames"][0]
    assert len(stored["geometry"]) == 13  # two capsules for each of the six links, and the tool's
    for view, (u, v) in VIEWS.items():
        m = view_mapping(page, view)
        for k, shape in enumerate(stored["geometry"]):
            line = page.locator(f"#{view} line.link[data-shape='{k}']")
            assert line.get_attribute("data-body") == shape["body"]
            ends = [
                to_mm(m, float(line.get_attribute(f"x{i}") or ""), float(line.get_attribute(f"y{i}") or ""))
                for i in (1, 2)
            ]
            for end, frame in zip(ends, (shape["from_frame"], shape["to_frame"]), strict=True):
                assert end == pytest.approx(tuple(np.array(frames[frame]["position"])[[u, v]]), abs=1e-6)
            assert float(line.get_attribute("stroke-width") or "") / m["scale"] == pytest.approx(2 * shape["radius_mm"])
        tracker = page.locator(f"#{view} circle.tracker")
        at = to_mm(m, float(tracker.get_attribute("cx") or ""), float(tracker.get_attribute("cy") or ""))
        assert at == pytest.approx(tuple(np.array(TRACKER["position_mm"])[[u, v]]), abs=1e-6)
        reach = float(page.get_attribute(f"#{view} circle.range-max", "r") or "") / m["scale"]
        assert reach == pytest.approx(stored["cell"]["tracker"]["range_max_mm"])
        assert page.locator(f"#{view} text.axis-label").all_text_contents() == [f"{'xyz'[u]} (mm)", f"{'xyz'[v]} (mm)"]


def _three_poses(server: str, robot_id: str) -> list[list[float]]:
    """A feasible pose, one the reflector faces away from the tracker in and one past a joint's range, chosen by
    the API's own check of a few candidates."""
    rng = np.random.default_rng(7)
    candidates = rng.uniform(-180, 180, size=(200, 6)).round(3).tolist()
    verdicts = httpx.post(f"{server}/v1/robots/{robot_id}/cell/check", json={"poses": candidates}, timeout=60).json()
    feasible = next(q for q, v in zip(candidates, verdicts["poses"], strict=True) if v["feasible"])
    facing_away = next(q for q, v in zip(candidates, verdicts["poses"], strict=True) if v["reason"] == "incidence")
    return [feasible, facing_away, [0, 0, 0, 0, 0, 200]]


def _rows(page: Any, selector: str) -> list[list[str]]:
    rows: list[list[str]] = page.eval_on_selector_all(
        f"{selector} tbody tr", "rows => rows.map(r => [...r.cells].map(c => c.textContent.trim()))"
    )
    return rows


def _upload(page: Any, server: str, robot_id: str, tmp_path: Path) -> None:
    """A bad document typed: the page shows the API's detail and each field it names, nothing is stored. Then a
    good one from a file, sent with the robot's ETag as the page read it."""
    bad = {**CELL, "obstacles": [{**TABLE, "size_mm": [1500, -1, 40]}], "clearance_mm": -1}
    said = httpx.put(f"{server}/v1/robots/{robot_id}/cell", json=bad).json()
    fields = [f"{e['field']}: {e['msg']}" for e in said["errors"]]
    assert any("size_mm" in f for f in fields) and any("clearance_mm" in f for f in fields)
    page.fill("#cell-document", json.dumps(bad))
    page.click("#cell-save")
    expect(page.locator("#cell-error li")).to_have_text(fields)
    assert page.locator("#cell-error p").inner_text() == f"422: {said['detail']}"
    screenshot(page, "cell-refused")
    assert httpx.get(f"{server}/v1/robots/{robot_id}/cell/versions").json() == []

    document = tmp_path / "cell.json"
    document.write_text(json.dumps(CELL))
    page.set_input_files("#cell-file", str(document))
    expect(page.locator("#cell-document")).to_have_value(json.dumps(CELL))
    etag = httpx.get(f"{server}/v1/robots/{robot_id}").headers["ETag"]  # as the page read it: nothing wrote since
    with page.expect_request(lambda r: r.method == "PUT") as sent:
        page.click("#cell-save")
    assert sent.value.headers["if-match"] == etag
    expect(page.locator("#cell-status")).to_contain_text("Version 1 (current)")
    page.wait_for_selector("#cell-top line.link", state="attached")  # a zero-length capsule is not "visible"


def _check_three(page: Any, server: str, robot_id: str) -> list[list[float]]:
    """Three poses pasted as CSV with the joint names as header: each verdict and the counts are the API's."""
    poses = _three_poses(server, robot_id)
    names = httpx.get(f"{server}/v1/robots/{robot_id}").json()["joint_names"]
    page.fill("#check-joints", "\n".join([",".join(names), *(",".join(map(str, q)) for q in poses)]))
    page.click("#check-submit")
    page.wait_for_selector("#check-poses")
    truth = httpx.post(f"{server}/v1/robots/{robot_id}/cell/check", json={"poses": poses}).json()
    rows = _rows(page, "#check-poses")
    assert [r[7:10] for r in rows] == [
        ["feasible" if v["feasible"] else "refused", v["reason"] or "", v["detail"] or ""] for v in truth["poses"]
    ]
    assert [r[0] for r in rows] == ["1", "2", "3"] and [r[8] for r in rows] == ["", "incidence", "joint_limits"]
    assert {r[0]: int(r[1]) for r in _rows(page, "#check-counts")} == truth["refused"]
    assert page.locator("#check-summary").inner_text() == "1 of 3 poses feasible in cell version 1."
    return poses


def test_a_cell_uploaded_drawn_checked_and_ended_by_clicks(page: Any, server: str, tmp_path: Path) -> None:
    robot_id = posted_ur5(server, "ur5-cell-ui")
    page.goto(f"{server}/ui#/robots/{robot_id}")
    ready(page, f"^#/robots/{robot_id}$")
    page.click("#go-cell")
    ready(page, "/cell$")
    expect(page.locator("#cell-status")).to_have_text("This robot has no cell yet.")
    _upload(page, server, robot_id, tmp_path)
    screenshot(page, "cell")
    stored = httpx.get(f"{server}/v1/robots/{robot_id}/cell").json()
    assert stored["version"] == 1 and len(stored["cell"]["obstacles"]) == 4
    _obstacles_drawn(page, stored["cell"])
    _robot_drawn(page, server, robot_id)
    version = _rows(page, "#cell-versions")
    assert len(version) == 1 and [version[0][k] for k in (0, 2, 3, 4)] == ["1", "anonymous", "4", "tracker"]

    poses = _check_three(page, server, robot_id)
    page.locator("#check-poses button[data-pose='2']").click()
    expect(page.locator("#cell-drawn")).to_contain_text("refused: incidence")
    assert [float(v) for v in page.get_attribute("#cell-views", "data-pose").strip("[]").split(",")] == poses[1]
    assert page.locator("#cell-top line.beam.refused").count() == 1
    _robot_drawn(page, server, robot_id)  # the links follow the pose chosen
    screenshot(page, "cell-checked")

    page.click("#cell-end")
    expect(page.locator("#cell-end")).to_contain_text("End it")
    page.click("#cell-end")
    expect(page.locator("#cell-status")).to_contain_text("Version 2 ended the cell")
    assert [v["ended"] for v in httpx.get(f"{server}/v1/robots/{robot_id}/cell/versions").json()] == [False, True]


def test_a_design_in_the_cell_shows_what_it_refused(page: Any, server: str) -> None:
    robot_id = posted_ur5(server, "ur5-cell-design")
    assert httpx.put(f"{server}/v1/robots/{robot_id}/cell", json=CELL).status_code == 200
    page.goto(f"{server}/ui#/robots/{robot_id}/design")
    ready(page, "/design$")
    page.fill("#design-count", "12")
    page.fill("#design-candidates", "200")
    page.select_option("#design-measurement", "position")
    page.check("#design-cell")
    with page.expect_request(lambda r: "/pose-designs" in r.url and r.method == "POST") as sent:
        page.click("#design-submit")
    assert sent.value.post_data_json["cell"] == "stored"
    page.wait_for_selector("#design-cell-views svg", timeout=PAGE_WAIT_MS)
    screenshot(page, "design-in-cell")
    designs = httpx.get(f"{server}/v1/robots/{robot_id}/pose-designs").json()
    design = httpx.get(f"{server}/v1/pose-designs/{designs[0]['id']}").json()
    c = design["cell"]
    assert c["version"] == 1 and c["feasible"] >= 200
    summary = page.locator("#design-cell-summary").inner_text()
    assert summary.startswith(
        f"{c['checked']} candidates checked against cell version 1: {c['feasible']} it can measure"
    )
    assert {r[0]: int(r[1]) for r in _rows(page, "#design-refused")} == c["refused"]
    assert {"incidence", "cell_collision"} <= set(c["refused"])
    # Every designed pose's TCP drawn where the API's forward kinematics puts it.
    fk = httpx.post(f"{server}/v1/robots/{robot_id}/forward-kinematics", json={"joints": design["poses"]}).json()
    for view, (u, v) in VIEWS.items():
        svg = page.locator(f"#design-cell-views #{view}")
        m = {k: float(svg.get_attribute(f"data-{k}") or "") for k in ("u0", "v1", "scale", "left", "top")}
        dots = svg.locator("circle.tcp-point")
        assert dots.count() == 12
        for k in range(12):
            dot = dots.nth(k)
            at = to_mm(m, float(dot.get_attribute("cx") or ""), float(dot.get_attribute("cy") or ""))
            assert at == pytest.approx(tuple(np.array(fk["poses"][k]["position"])[[u, v]]), abs=1e-6)
        assert svg.locator("polygon.obstacle").count() == 3 and svg.locator("line.link").count() == 13
