"""Compensation of targets given relative to another branch: the torch's pose in the part frame of a positioner
(whose joints the program sets), or one hand's in the other's, turned into the joints of the tool's own
branches that put it there on the calibrated tree.

The frame tool's pose follows from its joints (`tool_poses` on the calibrated parameters), so a relative target
is a world target: T = T_frame · T_rel. The tool's chain (`RobotTree.chain`) is split where it leaves the frame
tool's path: the shared prefix (the base, a waist both arms turn on) is set by the given joints, so each
target is expressed in the prefix's end frame, and the rest (the tool's own branches and its tool) is an
ordinary `RobotDescription` whose compensation is the chain's (`models.compensation.poses.compensate_near`):
Newton on the calibrated model from the program's joints, so the answer keeps the program's configuration.
Where nothing is shared (an arm beside a positioner on one floor), that description is the tool's own chain,
base included, and its runtime the chain's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array
from models.compensation.poses import compensate_near, pose_matrices
from models.errors import WrongShape
from models.kinematics import forward_kinematics
from models.robot import RobotDescription
from models.runtime import Registry, default_registry
from models.tree.kinematics import tool_poses, tree_joints
from models.tree.tree import RobotTree


@dataclass(frozen=True)
class RelativeCompensation:
    """Global joint vectors reaching relative targets on the calibrated tree, and the chain IK behind them."""

    joints: Array
    """(N, n_joints) the given joint vectors, the tool's own joints replaced by the compensated ones where
    reached (as given where not)."""
    moved: tuple[int, ...]
    """The global joints the compensation chose (the tool's own branches); the others are as given."""
    reached: NDArray[np.bool_]
    reasons: tuple[str | None, ...]
    """Why each target not reached was left (None where reached)."""


@dataclass(frozen=True)
class _Split:
    """The tool's chain cut where it leaves the frame's path."""

    prefix: RobotDescription | None
    """Base · shared stages (tool identity); None when only the base is shared."""
    prefix_params: NDArray[np.intp]
    """Global indices of the prefix's parameters but its (identity) tool."""
    prefix_joints: NDArray[np.intp]
    rest: RobotDescription
    rest_params: Array
    """The rest's parameter vector (its base: the identity when a prefix carries it)."""
    rest_joints: NDArray[np.intp]


def _split(tree: RobotTree, tool: str, frame: str, theta: Array) -> _Split:
    chain, sel = tree.chain(tool), tree.selection(tool)
    shared_branches = 0
    for mine, theirs in zip(tree.path(tool), tree.path(frame), strict=False):
        if mine.name != theirs.name:
            break
        shared_branches += 1
    cut = sum(len(b.own_stages) for b in tree.path(tool)[:shared_branches])
    placements = chain.placements
    tool_params = sel.params[chain.slices["tool"]]
    if cut == 0:
        # Only the base is shared: the tool's chain itself, with its base (targets stay in the world frame).
        return _Split(None, np.zeros(0, np.intp), np.zeros(0, np.intp), chain, theta[sel.params], sel.joints)
    params_at = [np.arange(6)] + [np.arange(p.params.start, p.params.stop) for p in placements[:cut]]
    prefix = RobotDescription(f"{chain.name}:prefix", chain.stages[:cut], base=chain.base, scales=chain.scales)
    prefix_joints = np.concatenate([np.arange(p.joints.start, p.joints.stop) for p in placements[:cut]])
    rest = RobotDescription(f"{chain.name}:rest", chain.stages[cut:], tool=chain.tool, scales=chain.scales)
    rest_params = np.concatenate(
        [np.zeros(6)] + [theta[sel.params[p.params]] for p in placements[cut:]] + [theta[tool_params]]
    )
    rest_joints = np.concatenate([np.arange(p.joints.start, p.joints.stop) for p in placements[cut:]])
    return _Split(
        prefix,
        sel.params[np.concatenate(params_at)],
        sel.joints[prefix_joints],
        rest,
        rest_params,
        sel.joints[rest_joints],
    )


def compensate_relative(
    tree: RobotTree,
    calibrated: ArrayLike,
    pair: tuple[str, str],
    joints: ArrayLike,
    targets: ArrayLike,
    *,
    registry: Registry | None = None,
) -> RelativeCompensation:
    """Joints putting tool `pair[0]` on `targets` ((N, 4, 4) poses in tool `pair[1]`'s frame, mm) on the tree
    with the `calibrated` parameters. `joints` (N, n_joints) set every joint the tool's own branches do not
    move (the positioner's, a shared waist) and, for the ones they move, are the program's (its nominal
    solution): the answer is the calibrated solution next to it, as the chain's compensation finds it
    (`compensate_near`: Newton from the program's joints; another configuration is refused with its reason)."""
    registry = registry or default_registry()
    tool, frame = pair
    theta = tree.parameters.vector(calibrated)
    tree.tip(tool)
    tree.tip(frame, "frame")
    q = tree_joints(tree, joints)
    n = q.shape[0]
    t_rel = np.asarray(targets, dtype=float)
    if t_rel.shape != (n, 4, 4) or not np.all(np.isfinite(t_rel)):
        raise WrongShape(f"targets must be {n} finite 4 x 4 poses, one per joint vector", field="targets")
    at = tool_poses(tree, frame, q, theta, registry=registry)
    world = pose_matrices(at.positions, at.rotations) @ t_rel  # T = T_frame · T_rel
    split = _split(tree, tool, frame, theta)
    if split.prefix is not None:
        # Into the prefix's end frame, which the given joints of the shared branches place.
        theta_prefix = np.concatenate([theta[split.prefix_params], np.zeros(6)])
        end = forward_kinematics(
            split.prefix,
            q[:, split.prefix_joints],
            theta_prefix,
            check_ranges=False,
            runtime=registry.runtime(split.prefix),
        )
        world = np.linalg.inv(pose_matrices(end.positions, end.rotations)) @ world
    solved, reached, reasons = compensate_near(
        split.rest, split.rest_params, world, q[:, split.rest_joints], runtime=registry.runtime(split.rest)
    )
    out = q.copy()
    out[np.ix_(reached, split.rest_joints)] = solved[reached]
    return RelativeCompensation(out, tuple(int(j) for j in split.rest_joints), reached, reasons)
