"""A calibrated tree written back: the URDF it was imported from with its moving joints' origins calibrated (a
drop-in: every link, joint, mesh and name as it was), and a DH table per branch that is a serial chain.

URDF. As for a chain (`models.formats.urdf_calibrated`): each MDH frame k of a branch and the URDF frame F_j of the
same joint are fixed to one link, so they differ by a constant C_k = J_k⁻¹ · F_j (both nominal, in base_link
at zero), a turn about and a shift along the joint's axis; the calibrated joint frame keeps that relation,
F_j = J_k · C_k, and the URDF's FK is the calibrated tree's. The tree's frames J_k are walked branch by
branch (its base, each branch's mount, its links at zero), in base_link's frame: the calibrated tree's world
is the instrument's, and the URDF's base_link sits at `world_from_base_link` in it (the calibrated base
after the nominal one, as a chain's export reports it). Every link of the tips' paths is then placed: a fixed
joint keeps its origin, a moving one gets its calibrated frame seen from its parent link. What no joint origin
holds, each tip's calibrated tool after its tip link, is `tip_to_tcp`. A parameter of a branch without tool
that a URDF piece cannot hold alone (the mount after a trunk: the trunk's last link to the arm's first joint)
lands in that first joint's origin, where it belongs.

DH tables. A branch of serial stages is a chain's table (`models.formats.dh_table`): its base is where it starts (the
tree's base for a branch from the base, its mount in its parent's end frame for the others), its tool its
tip's tool (the identity for a branch that only carries others).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from models._types import IDENTITY, Array
from models.description.robot import RobotDescription
from models.errors import InvalidInput
from models.formats.dh_table import DhTable, dh_table
from models.formats.joint_chain import joint_chain, pose_matrix
from models.formats.urdf import load_urdf, origin_mm
from models.formats.urdf_calibrated import splice_origins
from models.formats.urdf_tree import tree_parents
from models.stages import SerialStage
from models.tree.tree import RobotTree
from models.tree.urdf import tree_from_urdf


@dataclass(frozen=True)
class UrdfTreeCalibration:
    """The calibrated URDF and the frames it cannot hold."""

    urdf: str
    origins: dict[str, Array]
    """Each moving joint of the tips' paths: its calibrated origin (parent link <- joint frame, mm)."""
    world_from_base_link: Array
    """The instrument's frame <- base_link (mm), calibrated."""
    tip_to_tcp: dict[str, Array]
    """Each tip link -> its calibrated tool (mm)."""


def _branch_frames(tree: RobotTree, theta: Array) -> dict[str, list[Array]]:
    """Per branch, its links' MDH (or DH) joint frames at zero joints in the tree's world, then its end frame."""
    out: dict[str, list[Array]] = {}
    ends: dict[str | None, Array] = {None: pose_matrix(theta[:6])}
    for branch in tree.branches:
        start = ends[branch.parent]
        frames: list[Array] = []
        at = start
        for k, stage in enumerate(branch.own_stages):
            params = theta[tree.stage_params(branch.name, k)]
            if not isinstance(stage, SerialStage):
                at = at @ pose_matrix(params)  # a mount: the only other stage a URDF tree has
                continue
            desc = RobotDescription("piece", (stage,), scales=tree.scales)
            chain = joint_chain(desc, np.concatenate([np.zeros(6), params, np.zeros(6)]))
            for origin in chain.origins:
                at = at @ origin
                frames.append(at)
            at = at @ chain.flange
        ends[branch.name] = at
        out[branch.name] = [*frames, at]
    return out


def calibrate_urdf_tree(
    urdf: str, base_link: str, tree: RobotTree, params: ArrayLike, *, comment: str = "calibrated"
) -> UrdfTreeCalibration:
    """The URDF `tree` was read from (`tree_from_urdf(urdf, base_link, tips)`) with the values `params` (see the
    module docstring); InvalidInput when the URDF no longer reads as this tree."""
    tips = list(tree.tips)
    nominal_tree = tree_from_urdf(urdf, base_link, tips, name=tree.name)
    if [(b.name, b.parent, b.joint_names) for b in nominal_tree.branches] != [
        (b.name, b.parent, b.joint_names) for b in tree.branches
    ] or nominal_tree.parameters.names != tree.parameters.names:
        raise InvalidInput("the URDF no longer reads as this tree: export the DH tables instead", field="urdf")
    theta = tree.parameters.vector(params)
    nominal, calibrated = _branch_frames(tree, tree.parameters.nominal), _branch_frames(tree, theta)
    # The tree's nominal world is base_link; the calibrated world is the instrument's.
    world = pose_matrix(theta[:6]) @ np.linalg.inv(pose_matrix(tree.parameters.nominal[:6]))
    to_link = np.linalg.inv(world)
    parents = tree_parents(load_urdf(urdf))
    # Each moving joint -> (its branch, its frame's index in the branch).
    where = {name: (b.name, k) for b in tree.branches for k, name in enumerate(b.joint_names or ())}
    link_nominal: dict[str, Array] = {base_link: np.eye(4)}
    link_calibrated: dict[str, Array] = {base_link: np.eye(4)}
    origins: dict[str, Array] = {}
    for joint in _joints_down(parents, base_link, tips):
        f_nom = link_nominal[joint.parent] @ origin_mm(joint)
        link_nominal[joint.child] = f_nom
        if joint.type == "fixed":
            link_calibrated[joint.child] = link_calibrated[joint.parent] @ origin_mm(joint)
            continue
        branch, k = where[joint.name]
        j_nom, j_cal = nominal[branch][k], to_link @ calibrated[branch][k]
        f_cal = j_cal @ np.linalg.solve(j_nom, f_nom)  # J_k calibrated · C_k
        origins[joint.name] = np.asarray(np.linalg.solve(link_calibrated[joint.parent], f_cal), dtype=np.float64)
        link_calibrated[joint.child] = f_cal
    tip_to_tcp: dict[str, Array] = {}
    for tip in tips:
        tcp = to_link @ calibrated[tip][-1] @ pose_matrix(theta[tree.tool_slice(tip)])
        tip_to_tcp[tip] = np.asarray(np.linalg.solve(link_calibrated[tip], tcp), dtype=np.float64)
    return UrdfTreeCalibration(splice_origins(urdf, origins, comment), origins, world, tip_to_tcp)


def _joints_down(parents: dict[str, Any], base_link: str, tips: list[str]) -> list[Any]:
    """The joints (yourdfpy's) on the paths from `base_link` to the tips, each once, every parent link placed
    before its child."""
    seen: set[str] = set()
    ordered: list[Any] = []
    for tip in tips:
        path, at = [], tip
        while at != base_link:
            joint = parents[at]
            path.append(joint)
            at = joint.parent
        for joint in reversed(path):
            if joint.name not in seen:
                seen.add(joint.name)
                ordered.append(joint)
    return ordered


def branch_dh_tables(tree: RobotTree, params: ArrayLike) -> dict[str, DhTable]:
    """The DH table of every branch made of serial stages (see the module docstring), by branch name."""
    theta = tree.parameters.vector(params)
    out: dict[str, DhTable] = {}
    for branch in tree.branches:
        if not branch.stages or not all(isinstance(s, SerialStage) for s in branch.stages):
            continue
        base = theta[:6] if branch.parent is None and branch.mount is None else None
        if branch.mount is not None:
            base = theta[tree.stage_params(branch.name, 0)]
        if base is None:
            base = np.zeros(6)  # hangs from its parent's end frame directly: its table starts there
        own = [k for k, s in enumerate(branch.own_stages) if isinstance(s, SerialStage)]
        tool = theta[tree.tool_slice(branch.name)] if branch.tool is not None else np.array(IDENTITY, dtype=float)
        desc = RobotDescription(branch.name, tuple(branch.stages), scales=tree.scales)
        vector = np.concatenate([base, *(theta[tree.stage_params(branch.name, k)] for k in own), tool])
        out[branch.name] = dh_table(desc, vector)
    return out
