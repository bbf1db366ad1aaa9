"""A tree calibration's report, built from what the API serves (the stored calibration document, the tree's
document) and what the calibration stored to restate its fit: its records, its noise, its start.

The relative accuracy's figure is taken over joint vectors of the MEASURED region: uniform within each joint's
span over the fitted records (a hexapod's legs from platforms in its workspace, `tree_joint_samples`), at the
calibration's parameters with its covariance (`restated_fit`, the fit evaluated again at its stored solution).
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING, Any

import numpy as np

from models import Registry
from models.tree import RobotTree, accuracy_profiles, relative_changes, restated_fit, tree_joint_samples
from service.conversions.robot_trees import records_in, tree_in, tree_public
from service.conversions.units import instrument_noise
from service.persistence import Database
from service.persistence.robot_trees import TreeStore
from service.schemas.robot_trees import TreeCalibrationCreate
from service.services.robot_trees import calibration as calibration_document

if TYPE_CHECKING:
    from service.reports.tree import TreeReport

REGION_SAMPLES = 200
REGION_SEED = 20_470_047
"""One seed: a report drawn twice shows the same poses."""
REGION = (
    "Over {n} joint vectors drawn uniformly within each joint's span over the fitted records (a hexapod's legs from "
    "platforms in its workspace): the predicted 1-σ position error of each tool in the other's frame after the "
    "calibration, and how far the calibration moved that relative position (the error before it, as the fit sees "
    "it)."
)


def report_data(
    *, db: Database, tree_id: str, calibration_id: str
) -> tuple[RobotTree, dict[str, Any], dict[str, Any], dict[str, Any]]:
    """(the tree's model, the tree's document, the calibration's document, what it stored as its records)."""
    document = calibration_document(db=db, tree_id=tree_id, calibration_id=calibration_id).model_dump(mode="json")
    with db.reader() as s:
        store = TreeStore(s)
        row = store.tree(tree_id)
        tree = tree_in(row.document, row.name)
        tree_doc = tree_public(row, tree).model_dump(mode="json")
        stored = dict(store.calibration(calibration_id).records)
    return tree, tree_doc, document, stored


def region_joints(tree: RobotTree, stored: dict[str, Any]) -> tuple[np.ndarray, list[Any]]:
    """The region's joint vectors (internal units) and the fitted records' groups."""
    body = TreeCalibrationCreate.model_validate({k: stored[k] for k in ("records", "held_out") if k in stored})
    groups = list(records_in(tree, body.records, "records").groups)
    q = np.vstack([g.joints for g in groups])
    return tree_joint_samples(tree, REGION_SAMPLES, REGION_SEED, within=(q.min(axis=0), q.max(axis=0))), groups


def build_tree_report(*, db: Database, registry: Registry, tree_id: str, calibration_id: str) -> TreeReport:
    # The report package loads with its first report (matplotlib: 0.9 s of a process's start otherwise).
    from service.reports.tree import RelativeProfile, TreeReport  # noqa: PLC0415

    tree, tree_doc, document, stored = report_data(db=db, tree_id=tree_id, calibration_id=calibration_id)
    joints, groups = region_joints(tree, stored)
    defaults = TreeCalibrationCreate.model_fields
    noise = instrument_noise(
        float(stored.get("noise_position_mm", defaults["noise_position_mm"].default)),
        float(stored.get("noise_orientation_deg", defaults["noise_orientation_deg"].default)),
    )
    table = tree.parameters
    theta = np.array([p["value"] for p in document["parameters"]], dtype=float) / table.to_boundary
    estimated = [table.index[name] for name in document["estimated"]]
    start = np.asarray(stored["start"], dtype=float) if "start" in stored else None
    fit = restated_fit(tree, groups, theta, estimated, noise=noise, start=start, registry=registry)
    pairs = list(itertools.combinations(tree.tips, 2))
    profiles = accuracy_profiles(
        tree, theta, estimated, fit.parameter_covariance, joints, relative=pairs, registry=registry
    )
    moved = relative_changes(tree, start, theta, joints, pairs, registry=registry) if start is not None else {}
    return TreeReport(
        calibration=document,
        tree=tree_doc,
        profiles=[RelativeProfile(f"{a}/{b}", profiles[f"{a}/{b}"][0], moved.get(f"{a}/{b}")) for a, b in pairs],
        region=REGION.format(n=joints.shape[0]),
    )


def tree_report_html(*, db: Database, registry: Registry, tree_id: str, calibration_id: str) -> str:
    from service.reports.tree import render_html  # noqa: PLC0415

    return render_html(build_tree_report(db=db, registry=registry, tree_id=tree_id, calibration_id=calibration_id))


def tree_report_pdf(*, db: Database, registry: Registry, tree_id: str, calibration_id: str) -> bytes:
    from service.reports.tree import render_pdf  # noqa: PLC0415

    return render_pdf(build_tree_report(db=db, registry=registry, tree_id=tree_id, calibration_id=calibration_id))
