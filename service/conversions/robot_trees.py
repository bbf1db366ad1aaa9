"""Robots of several chains at the boundary: a tree document (mm, degrees, quaternions) as the models'
`RobotTree` (mm, radians, rotation vectors), a URDF's tree as a document, joints by name, records grouped by
what they measured, and the answers back in boundary units."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from models._types import IDENTITY, Array, Pose6
from models.description.parameters import Kind
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.joint_chain import pose_matrix
from models.formats.urdf import refuse_xacro
from models.stages import SerialStage, Stage
from models.stages.document import pose, pose_document
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np
from models.tree import Branch, MountStage, RobotTree, ToolAccuracy, ToolRecords, TreePoses, tree_from_urdf
from models.tree.kinematics import tree_joints
from service.compute import limits
from service.conversions.kinematics import unit_quaternion
from service.persistence.tables import RobotTreeRecord
from service.schemas.common import PosePublic, timestamp
from service.schemas.robot_trees import (
    RobotTreeCreate,
    RobotTreePublic,
    TreeBranchDocument,
    TreeParameterPublic,
    TreeRecord,
)

UNITS = {Kind.LENGTH: "mm", Kind.ANGLE: "deg"}


# ---------------------------------------------------------------------------------------------- documents
def ordered_branches(branches: Sequence[TreeBranchDocument]) -> list[tuple[int, TreeBranchDocument]]:
    """The branches with their request index, parents before children (else the request's order); a 422 naming
    the field for a duplicate name, an unknown parent, a cycle, a leaf without a tool."""
    index: dict[str, int] = {}
    for i, branch in enumerate(branches):
        if branch.name in index:
            raise InvalidInput(
                f"branches[{index[branch.name]}] and branches[{i}] are both named {branch.name!r}: rename one",
                field=f"branches[{i}].name",
                value=branch.name,
            )
        index[branch.name] = i
    for i, branch in enumerate(branches):
        if branch.parent is not None and branch.parent not in index:
            raise InvalidInput(
                f"branch {branch.name!r} hangs from {branch.parent!r}, which is no branch of the tree "
                f"({', '.join(index)})",
                field=f"branches[{i}].parent",
                value=branch.parent,
                allowed=list(index),
            )
    placed: set[str] = set()
    out: list[tuple[int, TreeBranchDocument]] = []
    while len(out) < len(branches):
        ready = [
            (i, b) for i, b in enumerate(branches) if b.name not in placed and (b.parent is None or b.parent in placed)
        ]
        if not ready:
            stuck = [b.name for b in branches if b.name not in placed]
            first = next(i for i, b in enumerate(branches) if b.name not in placed)
            raise InvalidInput(
                f"the branches {stuck} hang from each other in a cycle: one of them must hang from the base "
                "(parent null) or from a branch outside the cycle",
                field=f"branches[{first}].parent",
            )
        i, branch = ready[0]  # one at a time: the request's order wherever the parents allow it
        placed.add(branch.name)
        out.append((i, branch))
    parents = {b.parent for b in branches}
    for i, branch in enumerate(branches):
        if branch.name not in parents and branch.tool is None:
            raise InvalidInput(
                f"branch {branch.name!r} ends the tree (no branch hangs from it) but has no tool: give its tool "
                "(the TCP, the part frame) or leave the branch out",
                field=f"branches[{i}].tool",
            )
    return out


def _stages(branch: TreeBranchDocument, where: str) -> tuple[Stage, ...]:
    """The branch's stages read by the models' robots.md reader, its refusals naming the branch's field."""
    if not branch.stages:
        return ()
    try:
        desc = description_from_document({"stages": [s.model_dump() for s in branch.stages]})
    except InvalidInput as exc:
        exc.field = f"{where}.{exc.field}" if exc.field else where
        exc.detail = f"{where}: {exc.detail}"
        exc.args = (exc.detail,)
        raise
    return desc.stages


def _pose(value: Any, where: str) -> Pose6 | None:
    if value is None:
        return None
    data = value.model_dump() if hasattr(value, "model_dump") else value
    unit_quaternion(data["orientation"], where)  # a 422 naming the pose, as a robot's base
    return pose(data, where)


def tree_in(document: Mapping[str, Any], name: str = "robot-tree") -> RobotTree:
    """The models' tree of a stored (or requested) document: {base, branches} in boundary units."""
    body = RobotTreeCreate.model_validate(
        {"name": name, "base": document.get("base"), "branches": document["branches"]}
    )
    assert body.branches is not None
    return _tree(body.name, body.base, body.branches)


def _tree(name: str, base: Any, branches: Sequence[TreeBranchDocument]) -> RobotTree:
    built: list[Branch] = []
    links = 0
    for i, doc in ordered_branches(branches):
        where = f"branches[{i}]"
        stages = _stages(doc, where)
        links += sum(len(s.dh_links) for s in stages)
        if links > limits.TREE_LINKS_MAX:
            raise InvalidInput(
                f"the tree has more than {limits.TREE_LINKS_MAX} links in all (at {where})", field=f"{where}.stages"
            )
        joint_names = tuple(doc.joint_names) if doc.joint_names is not None else None
        built.append(
            Branch(
                doc.name,
                stages,
                parent=doc.parent,
                mount=_pose(doc.mount, f"{where}.mount"),
                tool=_pose(doc.tool, f"{where}.tool"),
                joint_names=joint_names,
            )
        )
    tree = RobotTree(name, tuple(built), base=_pose(base, "base") or IDENTITY)
    if tree.n_joints > limits.TREE_JOINTS_MAX:
        raise InvalidInput(
            f"the tree has {tree.n_joints} joints, over the limit of {limits.TREE_JOINTS_MAX}", field="branches"
        )
    index = {b.name: i for i, b in enumerate(branches)}
    seen: dict[str, str] = {}
    for branch in tree.branches:
        own = branch.joint_names or tuple(f"{branch.name}.q{k}" for k in range(1, branch.n_joints + 1))
        for joint in own:
            if joint in seen:
                # The field to fix: the names given by hand (a default `{branch}.q{k}` is not the user's).
                named = branch.name if branch.joint_names is not None else seen[joint]
                raise InvalidInput(
                    f"joint name {joint!r} is both branch {seen[joint]!r}'s and {branch.name!r}'s: joints are "
                    "named once in a tree",
                    field=f"branches[{index[named]}].joint_names",
                    value=joint,
                )
            seen[joint] = branch.name
    return tree


@dataclass(frozen=True)
class NewTree:
    tree: RobotTree
    document: dict[str, Any]
    """The tree as stored: base and branches in order, boundary units."""
    source: str
    urdf: dict[str, Any]
    """The URDF columns (urdf, base_link, tip_links), empty for a document."""


def new_tree(body: RobotTreeCreate) -> NewTree:
    """The tree a creation request asks for: from its branches, or from its URDF and tip links."""
    if body.urdf is not None:
        if body.branches is not None:
            raise InvalidInput("give branches or a urdf, not both", field="urdf")
        refuse_xacro(body.urdf)  # before base_link: a xacro's links are inside its macros
        if body.base_link is None:
            raise InvalidInput("a URDF tree needs base_link (the link its chains start from)", field="base_link")
        if body.tip_links is None:
            raise InvalidInput("a URDF tree needs tip_links (the links that carry its tools)", field="tip_links")
        read = tree_from_urdf(body.urdf, body.base_link, body.tip_links, name=body.name)
        document = document_of(read, base=body.base)
        urdf = {"urdf": body.urdf, "base_link": body.base_link, "tip_links": list(body.tip_links)}
        return NewTree(tree_in(document, body.name), document, "urdf", urdf)
    for field, value in (("base_link", body.base_link), ("tip_links", body.tip_links)):
        if value is not None:
            raise InvalidInput(f"{field} goes with a urdf: a tree of branches leaves it out", field=field)
    if body.branches is None:
        raise InvalidInput("a tree needs branches or a urdf with tip_links", field="branches")
    tree = _tree(body.name, body.base, body.branches)
    order = {b.name: b for b in body.branches}
    document = {
        "base": body.base.model_dump() if body.base is not None else None,
        "branches": [order[b.name].model_dump(exclude_none=True) for b in tree.branches],
    }
    return NewTree(tree, document, "document", {})


def _stage_slices(tree: RobotTree) -> dict[tuple[str, int], slice]:
    """(branch, own stage index) -> its global parameters: the tree's layout (base first, then each branch's
    own stages in order)."""
    out, at = {}, 6
    for branch in tree.branches:
        for k, stage in enumerate(branch.own_stages):
            out[branch.name, k] = slice(at, at + stage.n_params)
            at += stage.n_params
    return out


def document_of(tree: RobotTree, theta: Array | None = None, base: Any = None) -> dict[str, Any]:
    """The tree document of a models' tree at `theta` (default nominal): what a URDF import stores. `base`: the
    request's world <- base_link, composed before the URDF's own base."""
    values = tree.parameters.nominal if theta is None else theta
    slices = _stage_slices(tree)
    branches = []
    for branch in tree.branches:
        doc: dict[str, Any] = {"name": branch.name}
        if branch.parent is not None:
            doc["parent"] = branch.parent
        stages = []
        for k, stage in enumerate(branch.own_stages):
            p = values[slices[branch.name, k]]
            if isinstance(stage, MountStage):
                doc["mount"] = pose_document(p)
            else:
                stages.append(stage.document(p))
        doc["stages"] = stages
        if branch.tool is not None:
            doc["tool"] = pose_document(values[tree.tool_slice(branch.name)])
        if branch.joint_names is not None:
            doc["joint_names"] = list(branch.joint_names)
        branches.append(doc)
    own = values[:6]
    if base is not None:
        outer = _pose(base, "base")
        assert outer is not None
        own = _compose(np.asarray(outer, dtype=float), own)
    return {"base": pose_document(own), "branches": branches}


def _compose(a: Array, b: Array) -> Array:
    t = pose_matrix(a) @ pose_matrix(b)
    out: Array = np.r_[t[:3, 3], matrix_to_rotvec_np(t[:3, :3])]
    return out


# ---------------------------------------------------------------------------------------------- answers
def parameters_out(tree: RobotTree, values: Array, std: Array | None) -> list[TreeParameterPublic]:
    table = tree.parameters
    scale = table.to_boundary
    return [
        TreeParameterPublic(
            name=spec.name,
            group=spec.group,
            unit=UNITS.get(spec.kind, "mm"),  # type: ignore[arg-type]
            value=float(values[i] * scale[i]),
            nominal=float(spec.nominal * scale[i]),
            std_error=None if std is None or not np.isfinite(std[i]) else float(std[i] * scale[i]),
        )
        for i, spec in enumerate(table.specs)
    ]


def accuracy_out(found: Sequence[ToolAccuracy]) -> list[dict[str, Any]]:
    """Predicted accuracies as the API's `TreeAccuracyPublic` (deg for the orientation)."""
    return [
        {
            "label": a.label,
            "tool": a.label.split("/")[0],
            "frame": a.label.split("/")[1] if "/" in a.label else None,
            "rms_position_mm": a.rms_position_mm,
            "max_position_mm": a.max_position_mm,
            "rms_orientation_deg": math.degrees(a.rms_orientation_rad),
        }
        for a in found
    ]


def current_values(row: RobotTreeRecord, tree: RobotTree) -> tuple[Array, Array | None]:
    """The tree's current parameters (internal units) and their standard errors (None: nominal)."""
    if row.parameters is None:
        return tree.parameters.nominal.copy(), None
    std = np.array([np.nan if v is None else v for v in row.std_errors or []], dtype=float)
    return np.asarray(row.parameters, dtype=float), std if std.size == tree.n_params else None


def _pose_public(p: Any) -> PosePublic | None:
    return None if p is None else PosePublic.model_validate(pose_document(np.asarray(p, dtype=float)))


def joint_units(tree: RobotTree) -> list[str]:
    return [UNITS.get(kind, "mm") for kind in tree.joint_kinds]


def joint_scale(tree: RobotTree) -> Array:
    return np.array([kind.to_boundary for kind in tree.joint_kinds], dtype=float)


def tree_public(row: RobotTreeRecord, tree: RobotTree) -> RobotTreePublic:
    values, std = current_values(row, tree)
    slices = _stage_slices(tree)
    lo, hi = tree.joint_limits
    scale = joint_scale(tree)
    branches, at = [], 0
    for branch in tree.branches:
        n = branch.n_joints
        mount = None
        if branch.mount is not None:
            mount = values[slices[branch.name, 0]]
        tool = values[tree.tool_slice(branch.name)] if branch.tool is not None else None
        stages = next(s for s in row.document["branches"] if s["name"] == branch.name).get("stages", [])
        branches.append(
            {
                "name": branch.name,
                "parent": branch.parent,
                "children": [b.name for b in tree.branches if b.parent == branch.name],
                "mount": _pose_public(mount),
                "tool": _pose_public(tool),
                "joint_names": list(tree.joint_names[at : at + n]),
                "joint_units": joint_units(tree)[at : at + n],
                "joint_ranges": (np.c_[lo[at : at + n], hi[at : at + n]] * scale[at : at + n, None]).tolist(),
                "links": sum(len(s.dh_links) for s in branch.stages if isinstance(s, SerialStage)),
                "stages": stages,
            }
        )
        at += n
    groups: dict[str, list[str]] = {}
    for spec in tree.parameters.specs:
        groups.setdefault(spec.group, []).append(spec.name)
    return RobotTreePublic.model_validate(
        {
            "id": row.id,
            "name": row.name,
            "revision": row.revision,
            "created_at": timestamp(row.created_at),
            "source": row.source,
            "base_link": row.base_link,
            "tip_links": row.tip_links,
            "base": _pose_public(values[:6]),
            "branches": branches,
            "tools": list(tree.tips),
            "joint_names": list(tree.joint_names),
            "joint_units": joint_units(tree),
            "parameter_count": tree.n_params,
            "groups": groups,
            "parameters": parameters_out(tree, values, std),
            "calibration_id": row.calibration_id,
        }
    )


# ---------------------------------------------------------------------------------------------- joints, records
def joints_in(
    tree: RobotTree, rows: Sequence[Mapping[str, float] | Sequence[float]], where: str, suffix: str = ""
) -> Array:
    """(N, n_joints) internal units from joint vectors by name or in the tree's order (deg, mm); a 422 naming
    the row (`{where}[k]{suffix}`) and the joints missing or unknown."""
    names = tree.joint_names
    out = np.empty((len(rows), len(names)))
    for k, row in enumerate(rows):
        at = f"{where}[{k}]{suffix}"
        if isinstance(row, Mapping):
            missing = [n for n in names if n not in row]
            unknown = [n for n in row if n not in set(names)]
            if unknown:
                raise InvalidInput(
                    f"{at}: the tree has no joint {unknown[0]!r}; its joints are {list(names)}",
                    field=at,
                    value=unknown[0],
                    allowed=list(names),
                )
            if missing:
                raise InvalidInput(
                    f"{at}: joints {missing} are missing: give every joint of the tree {list(names)}",
                    field=at,
                    allowed=missing,
                )
            out[k] = [row[n] for n in names]
        else:
            if len(row) != len(names):
                raise InvalidInput(
                    f"{at}: {len(row)} joint values for the tree's {len(names)} joints {list(names)}",
                    field=at,
                )
            out[k] = row
    return tree_joints(tree, out / joint_scale(tree))


@dataclass(frozen=True)
class Grouped:
    """Records grouped as the models fit them: one `ToolRecords` per tool, frame, kind and σ."""

    groups: tuple[ToolRecords, ...]
    count: int


def records_in(tree: RobotTree, records: Sequence[TreeRecord], where: str) -> Grouped:
    """The records as `ToolRecords` groups (internal units); a 422 naming the record for a tool or a frame the
    tree does not have, missing joints or a quaternion that is not a unit one."""
    if not records:
        return Grouped((), 0)
    for k, record in enumerate(records):
        tree.check_record(record.tool, record.frame, f"{where}[{k}]")
        if record.orientation is not None:
            unit_quaternion(record.orientation, f"{where}[{k}].orientation")
    q = joints_in(tree, [r.joints for r in records], where, ".joints")
    keys: dict[tuple[str, str | None, bool, float | None], list[int]] = {}
    for k, record in enumerate(records):
        keys.setdefault((record.tool, record.frame, record.orientation is not None, record.sigma_mm), []).append(k)
    groups = []
    for (tool, frame, oriented, sigma), rows in keys.items():
        positions = np.array([records[k].position for k in rows], dtype=float)
        quats = None
        if oriented:
            quats = np.array([unit_quaternion(records[k].orientation or [], "orientation") for k in rows])
        groups.append(ToolRecords(tool, q[rows], positions, quats, frame, sigma))
    return Grouped(tuple(groups), len(records))


# ---------------------------------------------------------------------------------------------- kinematics
def poses_out(poses: TreePoses) -> list[dict[str, list[float]]]:
    """Each pose's position (mm), quaternion and rotation vector (deg), as the answer's plain values."""
    quats = matrix_to_quaternion(poses.rotations).tolist()
    rotvecs = np.degrees(matrix_to_rotvec_np(poses.rotations)).tolist()
    return [
        {"position": p, "orientation": o, "rotation_vector_deg": r}
        for p, o, r in zip(poses.positions.tolist(), quats, rotvecs, strict=True)
    ]


def frame_names(tree: RobotTree, tip: str) -> list[str]:
    """The names of the frames `models.cell.stage_frames` gives for `tip`'s chain, in its order: the base, each
    own stage's (a mount's, each serial link's middle and end, a parallel stage's end) by branch, the tool."""
    names = ["base"]
    for branch in tree.path(tip):
        number, stage_number = 1, 0
        for stage in branch.own_stages:
            if isinstance(stage, MountStage):
                names.append(f"{branch.name}.mount")
            elif isinstance(stage, SerialStage):
                for _ in stage.links:
                    names += [f"{branch.name}.link{number}.mid", f"{branch.name}.link{number}"]
                    number += 1
            else:
                stage_number += 1
                names.append(f"{branch.name}.stage{stage_number}")
    names.append(f"{tip}.tool")
    return names


def frames_out(names: Sequence[str], frames: Array) -> list[list[dict[str, Any]]]:
    """(N, F, 4, 4) world <- frame as, per joint vector, each frame's name, branch, position and quaternion
    (the quaternions in one call: per frame, 31 000 of them took 6 s)."""
    n, count = frames.shape[:2]
    quats = matrix_to_quaternion(frames[:, :, :3, :3].reshape(-1, 3, 3)).reshape(n, count, 4).tolist()
    positions = frames[:, :, :3, 3].tolist()
    branches = [None if name == "base" else name.split(".")[0] for name in names]
    return [
        [
            {"name": name, "branch": branch, "position": p, "orientation": o}
            for name, branch, p, o in zip(names, branches, ps, qs, strict=True)
        ]
        for ps, qs in zip(positions, quats, strict=True)
    ]
