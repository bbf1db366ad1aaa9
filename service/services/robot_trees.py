"""Robots of several chains (issue 47): created from a tree document or a URDF, read, deleted; their tools'
kinematics, absolute and relative; their calibration from records of any tool, with each tool's and each
pair's predicted accuracy, applied as a new revision of the tree's parameters."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from models import Registry
from models.cell import stage_frames
from models.errors import TooFewMeasurements
from models.tree import RobotTree, ToolRecords, TreeFit, identify_tree, relative_of, tool_poses, tree_accuracy
from service.conversions.robot_trees import (
    Grouped,
    accuracy_out,
    current_values,
    frame_names,
    frames_out,
    joints_in,
    new_tree,
    parameters_out,
    poses_out,
    records_in,
    tree_in,
    tree_public,
)
from service.conversions.units import instrument_noise
from service.errors import Conflict, NotFound
from service.persistence import Database
from service.persistence.lifecycle import Actor
from service.persistence.repository import new_id
from service.persistence.robot_trees import TreeStore, check_tree_revision, tree_etag
from service.persistence.tables import RobotTreeCalibrationRecord, RobotTreeRecord
from service.schemas.common import timestamp
from service.schemas.robot_trees import (
    RobotTreeCreate,
    RobotTreePublic,
    TreeCalibrationCreate,
    TreeCalibrationPublic,
    TreeErrorPublic,
    TreeKinematicsPublic,
    TreeKinematicsRequest,
)

NO_ACTOR = Actor()


def _model(row: RobotTreeRecord) -> RobotTree:
    return tree_in(row.document, row.name)


def create_tree(*, db: Database, body: RobotTreeCreate, actor: Actor = NO_ACTOR) -> tuple[RobotTreePublic, str]:
    """The tree built and checked first (a 422 names what is wrong), then stored; its ETag."""
    made = new_tree(body)
    with db.session() as s:
        row = TreeStore(s).add_tree(
            name=body.name, document=made.document, source=made.source, actor=actor, **made.urdf
        )
        return tree_public(row, made.tree), tree_etag(row)


def get_tree(*, db: Database, tree_id: str) -> tuple[RobotTreePublic, str]:
    with db.reader() as s:
        row = TreeStore(s).tree(tree_id)
        return tree_public(row, _model(row)), tree_etag(row)


def list_trees(*, db: Database, limit: int, offset: int) -> list[RobotTreePublic]:
    with db.reader() as s:
        return [tree_public(row, _model(row)) for row in TreeStore(s).trees(limit, offset)]


def delete_tree(*, db: Database, tree_id: str, actor: Actor = NO_ACTOR, if_match: str | None = None) -> None:
    with db.session() as s:
        store = TreeStore(s)
        row = store.tree(tree_id, lock=True)
        check_tree_revision(row, if_match)
        store.delete_tree(row, actor)


@dataclass(frozen=True)
class TreeSize:
    """What a tree's computations cost by: its parameters, tools and frames (one per link end and middle, mount,
    tool)."""

    parameters: int
    tools: int
    frames: int


def tree_size(*, db: Database, tree_id: str) -> TreeSize:
    """The size the admission of a computation on the tree needs (a 404 for no such tree)."""
    with db.reader() as s:
        tree = _model(TreeStore(s).tree(tree_id))
    return TreeSize(tree.n_params, len(tree.tips), sum(len(frame_names(tree, tip)) for tip in tree.tips))


def kinematics(*, db: Database, registry: Registry, tree_id: str, body: TreeKinematicsRequest) -> TreeKinematicsPublic:
    """Each tool's pose, each tool in each other's frame, and (with frames) every frame once, per joint vector;
    the tree's current parameters."""
    with db.reader() as s:
        row = TreeStore(s).tree(tree_id)
        tree = _model(row)
        theta, _ = current_values(row, tree)
        revision = row.revision
    q = joints_in(tree, body.joints, "joints")
    poses = {
        tip: tool_poses(tree, tip, q, theta, check_ranges=False, registry=registry) for tip in tree.tips
    }  # the ranges were checked with the joints, naming the joint vector
    tools = {tip: poses_out(p) for tip, p in poses.items()}
    relative = {f"{a}/{b}": poses_out(relative_of(poses[a], poses[b])) for a, b in itertools.permutations(tree.tips, 2)}
    chains: dict[str, list[str]] = {}
    unique: dict[str, np.ndarray] = {}  # frame name -> (N, 4, 4)
    if body.frames:
        for tip in tree.tips:
            chain, sel = tree.chain(tip), tree.selection(tip)
            found = stage_frames(chain, q[:, sel.joints], theta[sel.params], runtime=registry.runtime(chain))
            names = frame_names(tree, tip)
            assert len(names) == found.shape[1], (names, found.shape)
            chains[tip] = names
            for j, name in enumerate(names):
                unique.setdefault(name, found[:, j])  # a shared branch's frames are every chain's: kept once
    frames = frames_out(list(unique), np.stack(list(unique.values()), axis=1)) if body.frames else None
    answers = [
        {
            "tools": {tip: tools[tip][n] for tip in tree.tips},
            "relative": {label: values[n] for label, values in relative.items()},
            "frames": frames[n] if frames is not None else None,
            "chains": chains if body.frames else None,
        }
        for n in range(q.shape[0])
    ]
    return TreeKinematicsPublic.model_validate({"revision": revision, "poses": answers})


def _errors(
    tree: RobotTree, groups: Sequence[ToolRecords], theta: np.ndarray, registry: Registry, before: np.ndarray | None
) -> list[TreeErrorPublic]:
    """Per label (`tool`, `tool/frame`): the RMS and largest position error of its records at `theta` (and at
    `before`)."""
    by_label: dict[str, list[np.ndarray]] = {}
    by_label_before: dict[str, list[np.ndarray]] = {}
    for group in groups:
        at = group.model(tree, theta, registry, jacobian=False).positions - group.positions
        by_label.setdefault(group.label, []).append(np.linalg.norm(at, axis=1))
        if before is not None:
            was = group.model(tree, before, registry, jacobian=False).positions - group.positions
            by_label_before.setdefault(group.label, []).append(np.linalg.norm(was, axis=1))
    out = []
    for label, parts in by_label.items():
        e = np.concatenate(parts)
        previous = np.concatenate(by_label_before[label]) if before is not None else None
        out.append(
            TreeErrorPublic(
                label=label,
                records=int(e.size),
                rms_mm=float(np.sqrt(np.mean(e**2))),
                max_mm=float(e.max()),
                before_rms_mm=None if previous is None else float(np.sqrt(np.mean(previous**2))),
            )
        )
    return out


def calibrate(
    *,
    db: Database,
    registry: Registry,
    tree_id: str,
    body: TreeCalibrationCreate,
    actor: Actor = NO_ACTOR,
    if_match: str | None = None,
) -> TreeCalibrationPublic:
    """The tree's parameters from its records, from its current ones; stored, and applied when asked and the
    tree has not changed since it was read (otherwise stored, not applied, and a 409 naming it)."""
    with db.reader() as s:
        row = TreeStore(s).tree(tree_id)
        check_tree_revision(row, if_match)
        tree = _model(row)
        start, _ = current_values(row, tree)
        start_revision = row.revision
    fitted = records_in(tree, body.records, "records")
    held = records_in(tree, body.held_out, "held_out")
    noise = instrument_noise(body.noise_position_mm, body.noise_orientation_deg)
    try:
        fit = identify_tree(tree, fitted.groups, noise=noise, nominal=start, registry=registry)
    except TooFewMeasurements as exc:
        # The tree's records, not a chain's `measurements`: the detail says which list falls short.
        exc.field = "records"
        exc.detail = f"records: {exc.detail}"
        exc.args = (exc.detail,)
        raise
    answer = _answer(tree, fit, fitted, held, samples=body.accuracy_samples, registry=registry)
    answer |= {"id": new_id(), "tree_id": tree_id, "actor": actor.name, "start_revision": start_revision}
    return _stored(db, tree_id, body, fit, answer, actor=actor)


def _answer(
    tree: RobotTree, fit: TreeFit, fitted: Grouped, held: Grouped, *, samples: int, registry: Registry
) -> dict[str, Any]:
    """What the fit says, in boundary units: its parameters, residuals, held-out errors, predicted accuracy of
    each tool and of each pair of tools."""
    pairs = list(itertools.combinations(tree.tips, 2))
    accuracy = tree_accuracy(tree, fit, relative=pairs, samples=samples, registry=registry)
    names = tree.parameters.names
    return {
        "records": fitted.count,
        "held_out_records": held.count,
        "estimated": [names[i] for i in fit.estimated],
        "unidentifiable": list(fit.unidentifiable),
        "seen_by": {name: list(labels) for name, labels in fit.seen_by.items()},
        "fit": _errors(tree, fitted.groups, fit.parameters, registry, None),
        "held_out": _errors(tree, held.groups, fit.parameters, registry, fit.start),
        "accuracy": accuracy_out(accuracy),
        "variance_factor": float(fit.statistics.variance_factor),
        "noise_consistent": bool(fit.statistics.noise_consistent),
        "parameters": parameters_out(tree, fit.parameters, fit.std_errors),
        "seconds": fit.seconds,
    }


def _stored(
    db: Database, tree_id: str, body: TreeCalibrationCreate, fit: TreeFit, answer: dict[str, Any], *, actor: Actor
) -> TreeCalibrationPublic:
    """The calibration stored, applied when asked and the tree is still at its start revision; a 409 after the
    commit when it lost that race (stored, not applied)."""
    start_revision = answer["start_revision"]
    std = [None if not np.isfinite(v) else float(v) for v in fit.std_errors]
    with db.session() as s:
        store = TreeStore(s)
        row = store.tree(tree_id, lock=True)
        lost = body.apply and row.revision != start_revision
        revision = None
        if body.apply and not lost:
            revision = store.apply(row, answer["id"], fit.parameters.tolist(), std, actor)
        record = store.add_calibration(
            RobotTreeCalibrationRecord(
                id=answer["id"],
                tree_id=tree_id,
                applied=revision is not None,
                revision=revision,
                start_revision=start_revision,
                # What its report restates the fit from: the records, the noise, and where the fit started.
                records=body.model_dump(
                    mode="json", include={"records", "held_out", "noise_position_mm", "noise_orientation_deg"}
                )
                | {"start": fit.start.tolist()},
                result={},
                actor=actor.name,
            )
        )
        answer |= {"applied": revision is not None, "revision": revision, "created_at": timestamp(record.created_at)}
        public = TreeCalibrationPublic.model_validate(answer)
        record.result = public.model_dump(mode="json")
        current = row.revision
    if lost:
        raise Conflict(
            f"robot tree {tree_id!r} changed while it was calibrated (revision {start_revision} -> {current}): "
            f"calibration {answer['id']!r} is stored, not applied",
            calibration_id=answer["id"],
            start_version=start_revision,
            current_version=current,
        )
    return public


def calibrations(*, db: Database, tree_id: str, limit: int, offset: int) -> list[TreeCalibrationPublic]:
    with db.reader() as s:
        store = TreeStore(s)
        store.tree(tree_id)
        return [TreeCalibrationPublic.model_validate(r.result) for r in store.calibrations(tree_id, limit, offset)]


def calibration(*, db: Database, tree_id: str, calibration_id: str) -> TreeCalibrationPublic:
    with db.reader() as s:
        store = TreeStore(s)
        store.tree(tree_id)
        record = store.calibration(calibration_id)
        if record.tree_id != tree_id:
            raise NotFound(
                f"robot tree {tree_id!r} has no calibration {calibration_id!r}",
                resource="robot_tree_calibration",
                id=calibration_id,
            )
        return TreeCalibrationPublic.model_validate(record.result)
