"""What a robot of several chains is calibrated for, over HTTP (issue 47): which records to take (a design over
the tree's tools and relative pairs, against random selections), the joints that put a tool on a target in the
world or in another tool's frame on the calibrated tree, and the calibrated tree as a controller reads it (the
imported URDF with its calibrated joint origins, each branch's DH table).

Every operation reads the tree's current parameters (its last applied calibration's, else nominal) and says
which revision it used."""

from __future__ import annotations

import csv
import io
import itertools
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from models import Registry
from models._types import Array
from models.errors import InvalidInput
from models.formats.dh_table import LINK_TRANSFORMS, frame_row
from models.formats.urdf_calibrated import frame_text, splice_origins
from models.measurement import MeasurementKind
from models.transforms import matrix_to_rotvec_np, quaternion_to_matrix
from models.tree import (
    RobotTree,
    branch_dh_tables,
    calibrate_urdf_tree,
    compensate_relative,
    compensate_world,
    tree_joint_samples,
)
from optimal_design.tree import TreeCandidate, design_tree
from service.conversions.kinematics import unit_quaternion
from service.conversions.robot_trees import accuracy_out, current_values, joint_scale, joints_in, tree_in
from service.conversions.units import instrument_noise
from service.persistence import Database
from service.persistence.robot_trees import TreeStore
from service.schemas.exports import ROTATION
from service.schemas.robot_trees import (
    TreeCompensationCreate,
    TreeCompensationPublic,
    TreeDesignCreate,
    TreeDesignPublic,
    TreeDhExportPublic,
    TreeMeasured,
    TreeUrdfExportPublic,
)
from service.services.exports import FRAME_KEYS, WORLD

DRAW_MARGIN = 0.05
"""Drawn joint vectors stay this fraction of each joint's range inside it (as `tree_joint_samples`)."""


@dataclass(frozen=True)
class _Current:
    """The tree as its operations read it, in one transaction."""

    tree: RobotTree
    theta: Array
    revision: int
    calibration_id: str | None
    source: str
    urdf: str | None
    base_link: str | None
    name: str


def _current(db: Database, tree_id: str) -> _Current:
    with db.reader() as s:
        row = TreeStore(s).tree(tree_id)
        tree = tree_in(row.document, row.name)
        theta, _ = current_values(row, tree)
        return _Current(tree, theta, row.revision, row.calibration_id, row.source, row.urdf, row.base_link, row.name)


def _by_name(tree: RobotTree, q: Array) -> dict[str, float]:
    """One internal joint vector as the API's: by name, deg and mm."""
    return dict(zip(tree.joint_names, (q * joint_scale(tree)).tolist(), strict=True))


# ---------------------------------------------------------------------------------------------- designs
def _kinds(tree: RobotTree, measure: Sequence[TreeMeasured] | None) -> list[TreeMeasured]:
    """The kinds of record offered, each checked against the tree (a 422 naming `measure[k]`)."""
    if measure is None:
        return [TreeMeasured(tool=tip) for tip in tree.tips]
    seen: set[tuple[str, str | None, str]] = set()
    for k, kind in enumerate(measure):
        tree.tip(kind.tool, f"measure[{k}].tool")
        if kind.frame is not None:
            tree.tip(kind.frame, f"measure[{k}].frame")
            if kind.frame == kind.tool:
                raise InvalidInput(
                    f"measure[{k}]: a tool measured in its own frame says nothing", field=f"measure[{k}].frame"
                )
        key = (kind.tool, kind.frame, kind.measurement)
        if key in seen:
            raise InvalidInput(f"measure[{k}] repeats an earlier kind of record", field=f"measure[{k}]")
        seen.add(key)
    return list(measure)


def _drawn(tree: RobotTree, count: int, seed: int, ranges: Mapping[str, tuple[float, float]] | None) -> Array:
    """`count` joint vectors uniform within `ranges` (by name, deg and mm) and each other joint's range less
    DRAW_MARGIN at either end; a 422 naming the joint for an unknown one or a sub-range outside its range."""
    lo, hi = tree.joint_limits
    pad = DRAW_MARGIN * (hi - lo)
    lo, hi = lo + pad, hi - pad
    scale = joint_scale(tree)
    full_lo, full_hi = tree.joint_limits
    for name, (a, b) in (ranges or {}).items():
        where = f"joint_ranges.{name}"
        j = tree.joint_index(name, where)
        a_in, b_in = a / scale[j], b / scale[j]
        if not a_in < b_in or a_in < full_lo[j] - 1e-12 or b_in > full_hi[j] + 1e-12:
            unit = tree.joint_kinds[j].boundary_unit
            raise InvalidInput(
                f"{where}: [{a:g}, {b:g}] {unit} must be an interval (lo < hi) inside the joint's range "
                f"[{full_lo[j] * scale[j]:.6g}, {full_hi[j] * scale[j]:.6g}] {unit}",
                field=where,
            )
        lo[j], hi[j] = a_in, b_in
    # A hexapod's legs follow from its platform drawn in its workspace (`tree_joint_samples`), not from `ranges`.
    return tree_joint_samples(tree, count, seed, within=(lo, hi))


def _pairs(tree: RobotTree, kinds: Sequence[TreeMeasured]) -> list[tuple[str, str]]:
    """The relative pairs the design reports (and its I criterion weighs): those measured, then every other pair
    of tools once."""
    pairs: list[tuple[str, str]] = list(dict.fromkeys((k.tool, k.frame) for k in kinds if k.frame is not None))
    for a, b in itertools.combinations(tree.tips, 2):
        if (a, b) not in pairs and (b, a) not in pairs:
            pairs.append((a, b))
    return pairs


def design_cost_inputs(tree: RobotTree, body: TreeDesignCreate) -> tuple[int, int]:
    """(candidate records, rows of the largest) the admission of a design weighs."""
    return body.offered(len(tree.tips)), TreeMeasured.most_rows(body.measure)


def design(*, db: Database, registry: Registry, tree_id: str, body: TreeDesignCreate) -> TreeDesignPublic:
    """The records to take: `count` of the candidate records for the criterion, at the tree's current parameters,
    with the random baseline and each tool's and pair's predicted accuracy."""
    cur = _current(db, tree_id)
    tree = cur.tree
    kinds = _kinds(tree, body.measure)
    if body.candidates is not None:
        q = joints_in(tree, body.candidates, "candidates")
    else:
        q = _drawn(tree, body.candidate_count, body.seed, body.joint_ranges)
    candidates = [
        TreeCandidate(k.tool, row, k.frame, k.kind is MeasurementKind.POSITION, k.sigma_mm) for row in q for k in kinds
    ]
    if body.count > len(candidates):
        raise InvalidInput(
            f"count {body.count} is more than the {len(candidates)} candidate records ({q.shape[0]} joint vectors "
            f"x {len(kinds)} kinds): give more candidates or a smaller count",
            field="count",
            value=body.count,
        )
    noise = instrument_noise(body.noise_position_mm, body.noise_orientation_deg)
    found = design_tree(
        tree,
        candidates,
        body.count,
        body.criterion.value,
        relative=_pairs(tree, kinds),
        noise=noise,
        params=cur.theta,
        seed=body.seed,
        registry=registry,
    )
    return TreeDesignPublic.model_validate(
        {
            "tree_id": tree_id,
            "revision": cur.revision,
            "criterion": found.criterion.value,
            "count": len(found.chosen),
            "records": [
                {
                    "tool": c.tool,
                    "frame": c.frame,
                    "measurement": "position" if c.position_only else "pose",
                    "joints": _by_name(tree, c.joints),
                }
                for c in found.chosen
            ],
            "indices": list(found.indices),
            "value": found.value,
            "efficiency": found.efficiency,
            "metrics": found.metrics,
            "random_baseline": found.random_baseline,
            "accuracy": accuracy_out(found.accuracy),
            "random_accuracy": accuracy_out(found.random_accuracy),
            "identifiable": list(found.identifiable),
            "candidates": found.candidates,
            "seconds": found.seconds,
            "notes": list(found.notes),
        }
    )


def design_csv(tree_joint_names: Sequence[str], found: TreeDesignPublic) -> str:
    """The chosen records as a campaign sheet: tool, frame, measurement, then the tree's joints (deg, mm)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["tool", "frame", "measurement", *tree_joint_names])
    for r in found.records:
        writer.writerow([r.tool, r.frame or "", r.measurement, *(repr(r.joints[n]) for n in tree_joint_names)])
    return out.getvalue()


def joint_names(*, db: Database, tree_id: str) -> list[str]:
    with db.reader() as s:
        row = TreeStore(s).tree(tree_id)
        return list(tree_in(row.document, row.name).joint_names)


# ---------------------------------------------------------------------------------------------- compensation
def _targets_in(tree: RobotTree, body: TreeCompensationCreate) -> tuple[Array, Array]:
    """The targets' program joints (internal units) and poses (4 x 4, mm), each tool and frame checked."""
    quats = []
    for k, t in enumerate(body.targets):
        tree.tip(t.tool, f"targets[{k}].tool")
        if t.frame is not None:
            tree.tip(t.frame, f"targets[{k}].frame")
            if t.frame == t.tool:
                raise InvalidInput(
                    f"targets[{k}]: a tool's target in its own frame is where it already is",
                    field=f"targets[{k}].frame",
                )
        quats.append(unit_quaternion(t.orientation, f"targets[{k}].orientation"))
    q = joints_in(tree, [t.joints for t in body.targets], "targets", ".joints")
    poses = np.tile(np.eye(4), (len(body.targets), 1, 1))
    poses[:, :3, :3] = quaternion_to_matrix(np.array(quats))
    poses[:, :3, 3] = [t.position for t in body.targets]
    return q, poses


def compensate(
    *, db: Database, registry: Registry, tree_id: str, body: TreeCompensationCreate
) -> TreeCompensationPublic:
    """Each target's joints on the tree's current parameters, grouped by (tool, frame): Newton from the program's
    joints on the tool's own branches, a reason for each target left as given."""
    cur = _current(db, tree_id)
    tree = cur.tree
    targets = body.targets
    q, poses = _targets_in(tree, body)
    groups: dict[tuple[str, str | None], list[int]] = {}
    for k, t in enumerate(targets):
        groups.setdefault((t.tool, t.frame), []).append(k)
    joints = q.copy()
    reached = np.zeros(len(targets), dtype=bool)
    reasons: list[str | None] = [None] * len(targets)
    moved: dict[tuple[str, str | None], tuple[int, ...]] = {}
    for (tool, frame), rows in groups.items():
        try:
            if frame is None:
                found = compensate_world(tree, cur.theta, tool, q[rows], poses[rows], registry=registry)
            else:
                found = compensate_relative(tree, cur.theta, (tool, frame), q[rows], poses[rows], registry=registry)
        except InvalidInput as exc:
            if exc.field == "tool":  # no joint of its own: the first target that asks for it
                exc.field = f"targets[{rows[0]}].tool"
            raise
        joints[rows] = found.joints
        reached[rows] = found.reached
        for k, why in zip(rows, found.reasons, strict=True):
            reasons[k] = why
        moved[tool, frame] = found.moved
    scale = joint_scale(tree)
    names = tree.joint_names
    answers = []
    for k, t in enumerate(targets):
        own = moved[t.tool, t.frame]
        answers.append(
            {
                "tool": t.tool,
                "frame": t.frame,
                "reached": bool(reached[k]),
                "joints": _by_name(tree, joints[k]),
                "moved": [names[j] for j in own],
                "change": {names[j]: float((joints[k, j] - q[k, j]) * scale[j]) for j in own},
                "reason": reasons[k],
            }
        )
    return TreeCompensationPublic.model_validate(
        {
            "tree_id": tree_id,
            "revision": cur.revision,
            "calibration_id": cur.calibration_id,
            "targets": answers,
            "reached": int(reached.sum()),
        }
    )


# ---------------------------------------------------------------------------------------------- exports
def _frame(t: Array) -> dict[str, float]:
    """A 4 x 4 transform (mm) as the exports' frame: x, y, z and URDF's roll, pitch, yaw (deg)."""
    return asdict(frame_row(np.r_[t[:3, 3], matrix_to_rotvec_np(t[:3, :3])]))


@dataclass(frozen=True)
class UrdfExport:
    xml: str
    public: TreeUrdfExportPublic


def urdf_export(*, db: Database, tree_id: str) -> UrdfExport:
    """The URDF the tree was imported from, its moving joints' origins calibrated (a drop-in), with what no
    joint origin holds in a comment at its top and beside it: world <- base_link and each tip -> its TCP. A 422
    for a tree given as a document: it has no URDF to drop into."""
    cur = _current(db, tree_id)
    if cur.source != "urdf" or cur.urdf is None or cur.base_link is None:
        raise InvalidInput(
            f"robot tree {tree_id!r} was given as a document of branches, not imported from a URDF: it has no URDF "
            "to write the calibration into; export its DH tables (…/exports/dh) instead",
            field="source",
            value=cur.source,
        )
    title = f"robot tree {cur.name!r} (id {tree_id}), revision {cur.revision}"
    origin = f"calibration {cur.calibration_id}" if cur.calibration_id is not None else "nominal: not calibrated"
    found = calibrate_urdf_tree(cur.urdf, cur.base_link, cur.tree, cur.theta)
    lines = [
        f"Calibrated by the calibration service: {title} ({origin}).",
        f"Only the origins of the moving joints from {cur.base_link!r} to the tips {list(cur.tree.tips)} differ from",
        "the imported document. Frame: every chain starts at base_link as imported.",
        f"{WORLD}.",
        f"world_from_base_link {FRAME_KEYS}: {frame_text(found.world_from_base_link)}",
        *(f"tip_to_tcp[{tip}] {FRAME_KEYS}: {frame_text(t)}" for tip, t in found.tip_to_tcp.items()),
        "(the TCPs are the tools the calibration measured.)",
    ]
    # The comment states the frames, so it is spliced after they are known: the same origins, written with it.
    xml = splice_origins(cur.urdf, found.origins, "\n".join(lines))
    public = TreeUrdfExportPublic.model_validate(
        {
            "tree_id": tree_id,
            "revision": cur.revision,
            "base_link": cur.base_link,
            "urdf": xml,
            "world_from_base_link": _frame(found.world_from_base_link),
            "tip_to_tcp": {tip: _frame(t) for tip, t in found.tip_to_tcp.items()},
            "rotation": ROTATION,
        }
    )
    return UrdfExport(xml, public)


def dh_export(*, db: Database, tree_id: str) -> TreeDhExportPublic:
    """Each branch of serial stages as a DH (or MDH) table at the tree's current parameters."""
    cur = _current(db, tree_id)
    tables = branch_dh_tables(cur.tree, cur.theta)
    branches = []
    for branch in cur.tree.branches:
        table = tables.get(branch.name)
        if table is None:
            continue
        if branch.parent is None:
            frame = f"base maps the branch's first frame into the {WORLD}"
        else:
            frame = f"base maps the branch's first frame into branch {branch.parent!r}'s end frame (its last link's)"
        branches.append(
            {
                "branch": branch.name,
                "parent": branch.parent,
                "frame": frame,
                "base": asdict(table.base),
                "links": [asdict(row) for row in table.links],
                "tool": asdict(table.tool),
            }
        )
    return TreeDhExportPublic.model_validate(
        {
            "tree_id": tree_id,
            "revision": cur.revision,
            "pose": "parent's end frame (the world for a branch from the base) <- branch end = base · A_1(q) ⋯ "
            "A_n(q); <- its tool: · tool. A tool's pose is its path's tables composed from the base",
            "link_transforms": LINK_TRANSFORMS,
            "rotation": ROTATION,
            "branches": branches,
            "left_out": [b.name for b in cur.tree.branches if b.name not in tables],
        }
    )


DH_CSV_HEADER = (
    "branch", "row", "name", "type", "convention", "theta_deg", "d_mm", "a_mm", "alpha_deg", "beta_deg",
    "range_min", "range_max", "x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg",
)  # fmt: skip


def dh_csv(found: TreeDhExportPublic) -> str:
    """The tables as one sheet: per branch its base row, a row per link, its tool row (the frames' columns on
    base and tool, the DH columns on links)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(DH_CSV_HEADER)
    empty_dh = [""] * 7
    for b in found.branches:
        writer.writerow([b.branch, "base", "", "base", "", *empty_dh, *_frame_cells(b.base)])
        for link in b.links:
            lo, hi = ("", "") if link.range is None else (str(link.range[0]), str(link.range[1]))
            writer.writerow(
                [
                    b.branch, link.joint, link.name or "", link.type, link.convention, link.theta_deg, link.d_mm,
                    link.a_mm, link.alpha_deg, "" if link.beta_deg is None else link.beta_deg, lo, hi, *[""] * 6,
                ]
            )  # fmt: skip
        writer.writerow([b.branch, "tool", "", "tool", "", *empty_dh, *_frame_cells(b.tool)])
    return out.getvalue()


def _frame_cells(f: Any) -> list[float]:
    return [f.x_mm, f.y_mm, f.z_mm, f.roll_deg, f.pitch_deg, f.yaw_deg]
