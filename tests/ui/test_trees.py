"""Robots of several chains in /ui (issue 47): a dual-arm torso created through the API shows its branches as a
diagram (base → waist → both arms, a tool at each arm), is drawn at a pose whose tools, measured back in mm from
each view's mapping, sit where the API's kinematics put them; an arm and its positioner calibrated through the
API show each tool's and the pair's (relative) predicted accuracy as the API states them; a tree document with a
cycle typed in the page shows the API's refusal naming the field, and a good one opens its page; a design made in
the page shows the API's records and saves them as CSV, a compensation and a DH export run from it."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from playwright.sync_api import expect

from models.noise import NoiseModel
from models.tree import measure_tree, perturbed_tree, tree_joint_samples
from models.tree.examples import arm_with_positioner
from tests.models.test_tree_compensation import _away_from_singularities
from tests.service.trees import positioner_document, record_docs, torso_document
from tests.ui.conftest import PAGE_WAIT_MS, screenshot, watched_page
from tests.ui.pages import ready, to_mm, view_mapping

pytestmark = pytest.mark.slow  # a browser against the live server of tests/ui

VIEWS = {"cell-top": (0, 1), "cell-side": (0, 2), "cell-front": (1, 2)}


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[Any]:
    yield from watched_page(browser, server, viewport={"width": 1400, "height": 1000})


def _create(server: str, body: dict[str, Any]) -> dict[str, Any]:
    made = httpx.post(f"{server}/v1/robot-trees", json=body, timeout=60)
    assert made.status_code == 201, made.text
    found: dict[str, Any] = made.json()
    return found


def test_the_tree_view_shows_the_branches_and_draws_the_tools_where_the_api_puts_them(page: Any, server: str) -> None:
    tree = _create(server, torso_document("ui-torso"))
    page.goto(f"{server}/ui#/trees/{tree['id']}")
    ready(page, f"#/trees/{tree['id']}")
    expect(page.locator("#tree-views svg")).to_have_count(3)
    diagram = page.locator("#tree-diagram")
    assert [n.get_attribute("data-branch") for n in diagram.locator("rect.tree-node").all()] == [
        "base",
        "waist",
        "left",
        "right",
    ]
    edges = {(e.get_attribute("data-from"), e.get_attribute("data-to")) for e in diagram.locator("line[data-to]").all()}
    assert edges == {("base", "waist"), ("waist", "left"), ("waist", "right")}
    assert [t.get_attribute("data-tool") for t in diagram.locator("circle.tree-tool").all()] == ["left", "right"]
    assert page.locator("#tree-branches tbody tr").count() == 3

    joints = json.loads(page.get_attribute("#tree-views", "data-pose") or "[]")
    assert len(joints) == len(tree["joint_names"])
    fk = httpx.post(f"{server}/v1/robot-trees/{tree['id']}/kinematics", json={"joints": [joints]}, timeout=60)
    answer = fk.json()["poses"][0]
    frames = {f["name"]: f for f in answer["frames"]}
    for view, (u, v) in VIEWS.items():
        m = view_mapping(page, view)
        for tool in ("left", "right"):
            marker = page.locator(f"#{view} circle.tool-point[data-tool={tool}]")
            at = to_mm(m, float(marker.get_attribute("cx") or ""), float(marker.get_attribute("cy") or ""))
            assert at == pytest.approx(tuple(np.array(answer["tools"][tool]["position"])[[u, v]]), abs=1e-6)
        # Every link drawn joins two of the API's frames; the waist's once although both chains pass it.
        links = page.locator(f"#{view} line.tree-link").all()
        assert sum(line.get_attribute("data-branch") == "waist" for line in links) == 2
        for line in links[:8]:
            for end, name in ((1, line.get_attribute("data-from")), (2, line.get_attribute("data-to"))):
                x, y = (float(line.get_attribute(f"{c}{end}") or "") for c in "xy")
                assert to_mm(m, x, y) == pytest.approx(tuple(np.array(frames[name]["position"])[[u, v]]), abs=1e-6)
    shown = page.locator("#tree-tool-poses tbody tr").first.locator("td").nth(1).text_content() or ""
    assert [float(v) for v in shown.split(", ")] == pytest.approx(answer["tools"]["left"]["position"], rel=1e-5)

    # Another pose typed: the left tool moves where the API says.
    page.fill("#tree-pose", ", ".join(["30"] + ["10"] * (len(joints) - 1)))
    page.click("#tree-draw")
    expect(page.locator("#tree-views")).to_have_attribute("data-pose", re.compile(r"^\[30,"))
    moved = httpx.post(
        f"{server}/v1/robot-trees/{tree['id']}/kinematics",
        json={"joints": [[30.0] + [10.0] * (len(joints) - 1)], "frames": False},
        timeout=60,
    ).json()["poses"][0]["tools"]["left"]["position"]
    m = view_mapping(page, "cell-top")
    marker = page.locator("#cell-top circle.tool-point[data-tool=left]")
    at = to_mm(m, float(marker.get_attribute("cx") or ""), float(marker.get_attribute("cy") or ""))
    assert at == pytest.approx(tuple(moved[:2]), abs=1e-6)
    screenshot(page, "tree-torso")


def test_a_calibrated_tree_shows_each_tools_and_the_relative_accuracy(page: Any, server: str) -> None:
    tree = _create(server, positioner_document("ui-positioner"))
    models_tree = arm_with_positioner()
    sim = perturbed_tree(models_tree, seed=11)
    q = tree_joint_samples(models_tree, 20, seed=12)
    noise = NoiseModel(position_mm=0.02)
    groups = [measure_tree(sim, tip, q, noise=noise, seed=k) for k, tip in enumerate(models_tree.tips)]
    groups.append(measure_tree(sim, "arm", q, frame="positioner", noise=noise, seed=7))
    body = {"records": record_docs(groups, models_tree), "noise_position_mm": 0.02}
    calibrated = httpx.post(f"{server}/v1/robot-trees/{tree['id']}/calibrations", json=body, timeout=120)
    assert calibrated.status_code == 201, calibrated.text
    answer = calibrated.json()
    page.goto(f"{server}/ui#/trees/{tree['id']}")
    ready(page, f"#/trees/{tree['id']}")
    rows = page.locator("#tree-accuracy tbody tr")
    expect(rows).to_have_count(3)
    shown = {
        (row.locator("td").nth(0).text_content() or ""): [
            float(row.locator("td").nth(k).text_content() or "") for k in (2, 3, 4)
        ]
        for row in rows.all()
    }
    assert set(shown) == {"arm", "positioner", "arm/positioner"}
    for a in answer["accuracy"]:
        expected = [a["rms_position_mm"], a["max_position_mm"], a["rms_orientation_deg"]]
        assert shown[a["label"]] == pytest.approx(expected, rel=1e-3)  # four significant digits
    expect(page.locator("#tree-calibration")).to_contain_text(f"applied as revision {answer['revision']}")
    screenshot(page, "tree-calibrated")


def test_a_tree_typed_in_the_page_is_refused_naming_the_field_or_opened(page: Any, server: str) -> None:
    page.goto(f"{server}/ui#/trees")
    ready(page, "#/trees")
    bad = torso_document("ui-cycle")
    bad["branches"][1]["parent"] = "left"
    page.fill("#tree-document", json.dumps(bad))
    page.click("#tree-create")
    expect(page.locator("#tree-error")).to_contain_text("cycle")
    assert all(t["name"] != "ui-cycle" for t in httpx.get(f"{server}/v1/robot-trees", timeout=60).json())
    page.fill("#tree-document", json.dumps(torso_document("ui-typed")))
    page.click("#tree-create")
    ready(page, r"#/trees/[0-9a-f-]{36}")
    expect(page.locator("h1")).to_have_text("ui-typed")
    expect(page.locator("#tree-diagram rect.tree-node")).to_have_count(4)


def test_a_design_its_csv_a_compensation_and_an_export_from_the_tree_page(page: Any, server: str) -> None:
    tree = _create(server, positioner_document("ui-design"))
    page.goto(f"{server}/ui#/trees/{tree['id']}")
    ready(page, f"#/trees/{tree['id']}")
    page.fill("#tree-design-count", "20")
    page.fill("#tree-design-candidates", "60")
    page.fill("#tree-design-seed", "4")
    page.select_option("#tree-design-criterion", "D")
    page.click("#tree-design-run")
    rows = page.locator("#tree-design-records tbody tr")
    expect(rows).to_have_count(20, timeout=PAGE_WAIT_MS)
    measure = [{"tool": tool, "measurement": "position"} for tool in ("arm", "positioner")]
    body = {"count": 20, "criterion": "D", "candidate_count": 60, "seed": 4, "measure": measure}
    design = httpx.post(f"{server}/v1/robot-trees/{tree['id']}/designs", json=body, timeout=120).json()
    names = tree["joint_names"]
    first = [c.text_content() or "" for c in rows.first.locator("td").all()]
    assert first[1] == design["records"][0]["tool"]
    assert [float(v) for v in first[4:]] == pytest.approx([design["records"][0]["joints"][n] for n in names], rel=1e-3)
    with page.expect_download() as saved:
        page.click("#tree-design-csv")
    sheet = Path(saved.value.path()).read_text().splitlines()
    assert sheet[0].split(",") == ["tool", "frame", "measurement", *names]
    for line, record in zip(sheet[1:], design["records"], strict=True):
        cells = line.split(",")
        assert cells[0] == record["tool"] and [float(v) for v in cells[3:]] == [record["joints"][n] for n in names]

    # A world target the nominal tree reaches at the program's own joints (away from the arm's singular
    # configurations): reached, nothing changed.
    joints = np.degrees(_away_from_singularities(arm_with_positioner(), "arm")[0]).tolist()
    page.fill("#tree-comp-joints", ", ".join(repr(v) for v in joints))
    fk = httpx.post(f"{server}/v1/robot-trees/{tree['id']}/kinematics", json={"joints": [joints], "frames": False},
                    timeout=60).json()["poses"][0]["tools"]["arm"]  # fmt: skip
    page.fill("#tree-comp-position", ", ".join(repr(v) for v in fk["position"]))
    page.fill("#tree-comp-orientation", ", ".join(repr(v) for v in fk["orientation"]))
    page.click("#tree-comp-run")
    expect(page.locator("#tree-comp-status")).to_contain_text("Reached on revision 1 (nominal)")
    changes = [
        float(r.locator("td").nth(3).text_content() or "")
        for r in page.locator("#tree-comp-joints-table tbody tr").all()
    ]
    assert max(abs(v) for v in changes) < 1e-6

    with page.expect_download() as saved:
        page.click("#tree-export-dh-csv")
    assert Path(saved.value.path()).read_text().startswith("branch,row,name,type")
    expect(page.locator("#tree-export-urdf")).to_have_count(0)  # a tree given as a document has no URDF
    screenshot(page, "tree-design")
