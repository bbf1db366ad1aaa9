"""A tree calibration's report (issue 47): its numbers are the calibration document's, a typed name is escaped,
and the relative accuracy it draws is `tree_accuracy`'s over the same joint vectors of a fit made again here from
the same records (the report restates its fit from what was stored: a different path to the same covariance)."""

from __future__ import annotations

import html
import re
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import Registry
from models.tree import (
    RobotTree,
    identify_tree,
    measure_tree,
    perturbed_tree,
    relative_poses,
    tree_accuracy,
    tree_joint_samples,
)
from models.tree.examples import arm_with_positioner
from service.reports.tree import sorted_profile
from service.services.tree_reports import build_tree_report, region_joints
from tests.service.trees import NOISE, calibrate_tree, create_tree, positioner_document, record_docs

NAME = "cell <script>alert(1)</script>"


@pytest.fixture(scope="module")
def calibrated(api: TestClient) -> dict[str, Any]:
    """The arm and positioner cell, named with markup, calibrated from 16 poses of both tools and held-out ones."""
    tree = arm_with_positioner()
    made = create_tree(api, positioner_document(NAME))
    sim = perturbed_tree(tree, seed=31)
    q = tree_joint_samples(tree, 16, seed=32)
    groups = [measure_tree(sim, tip, q, noise=NOISE, seed=k) for k, tip in enumerate(tree.tips)]
    held = [measure_tree(sim, tip, tree_joint_samples(tree, 6, seed=33), noise=NOISE, seed=9) for tip in tree.tips]
    body = {"records": record_docs(groups, tree), "held_out": record_docs(held, tree), "noise_position_mm": 0.02}
    return {"tree": tree, "groups": groups, "answer": calibrate_tree(api, made["id"], body)}


def _values(page: str) -> dict[str, str]:
    return {k: html.unescape(v) for k, v in re.findall(r'data-key="([^"]+)" data-value="([^"]*)"', page)}


@pytest.mark.slow  # a fit, a restated one and the figures drawn: about a second of CPU
def test_the_reports_numbers_are_the_calibrations_and_the_name_is_escaped(
    api: TestClient, calibrated: dict[str, Any]
) -> None:
    c = calibrated["answer"]
    page = api.get(f"/v1/robot-trees/{c['tree_id']}/calibrations/{c['id']}/report")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    # The API's other HTML's policy (service.http.app.DOCUMENT_POLICY): no script at all, sandboxed.
    policy = page.headers["content-security-policy"]
    assert "default-src 'none'" in policy and "sandbox" in policy and "script-src" not in policy
    text = page.text
    assert "<script>" not in text and html.escape(NAME) in text
    values = _values(text)
    for key in ("fit", "held_out"):
        for e in c[key]:
            assert float(values[f"{key}.{e['label']}.RMS (mm)"]) == e["rms_mm"]
            assert float(values[f"{key}.{e['label']}.max (mm)"]) == e["max_mm"]
            assert int(values[f"{key}.{e['label']}.records"]) == e["records"]
    for e in c["held_out"]:
        assert float(values[f"held_out.{e['label']}.RMS before (mm)"]) == e["before_rms_mm"]
    for a in c["accuracy"]:
        assert float(values[f"accuracy.{a['label']}.RMS position (mm)"]) == a["rms_position_mm"]
        assert float(values[f"accuracy.{a['label']}.max position (mm)"]) == a["max_position_mm"]
    assert float(values["variance_factor"]) == c["variance_factor"]
    assert 'id="fig-tool-errors"' in text and 'id="fig-relative-accuracy"' in text
    assert "<td>positioner</td>" in text and "(base)" in text  # the branches listed
    pdf = api.get(f"/v1/robot-trees/{c['tree_id']}/calibrations/{c['id']}/report?format=pdf")
    assert pdf.status_code == 200 and pdf.content.startswith(b"%PDF")
    missing = api.get(f"/v1/robot-trees/{c['tree_id']}/calibrations/nope/report")
    assert missing.status_code == 404


@pytest.mark.slow  # two fits of the cell and the accuracy over 200 poses: about a second of CPU
def test_the_drawn_relative_accuracy_is_tree_accuracys_over_the_measured_region(
    api: TestClient, calibrated: dict[str, Any], registry: Registry
) -> None:
    c = calibrated["answer"]
    tree: RobotTree = calibrated["tree"]
    app_db = api.app.state.db  # type: ignore[attr-defined]
    report = build_tree_report(db=app_db, registry=registry, tree_id=c["tree_id"], calibration_id=c["id"])
    stored = {"records": record_docs(calibrated["groups"], tree)}
    joints, _ = region_joints(tree, stored)
    # The region: inside each joint's span over the records, and not the whole range.
    q = np.vstack([g.joints for g in calibrated["groups"]])
    assert np.all(joints >= q.min(axis=0) - 1e-12) and np.all(joints <= q.max(axis=0) + 1e-12)
    # A fit made again from the same records, its start the tree's nominal (where the API's began).
    fit = identify_tree(tree, calibrated["groups"], noise=NOISE)
    expected = {a.label: a for a in tree_accuracy(tree, fit, relative=[("arm", "positioner")], joints=joints)}
    (profile,) = report.profiles
    assert profile.label == "arm/positioner"
    x, y = sorted_profile(profile.predicted_mm)  # what the figure plots
    assert x[-1] == 1.0 and np.all(np.diff(y) >= 0)
    assert np.sqrt(np.mean(y**2)) == pytest.approx(expected["arm/positioner"].rms_position_mm, rel=1e-6)
    assert y.max() == pytest.approx(expected["arm/positioner"].max_position_mm, rel=1e-6)
    # Moved by the fit: the relative position at the start against at the solution, computed here directly.
    assert profile.moved_mm is not None
    p0 = relative_poses(tree, "arm", "positioner", joints, fit.start, check_ranges=False).positions
    p1 = relative_poses(tree, "arm", "positioner", joints, fit.parameters, check_ranges=False).positions
    np.testing.assert_allclose(profile.moved_mm, np.linalg.norm(p1 - p0, axis=1), rtol=1e-5, atol=1e-6)
    # The calibration is worth having: it moved the relative position far more than it is now uncertain.
    assert np.sqrt(np.mean(profile.moved_mm**2)) > 10 * np.sqrt(np.mean(y**2))
