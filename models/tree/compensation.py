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

A target in the world (`compensate_world`) is cut the same way where the tool's path leaves every other tool's:
a waist or a track that also carries another tool is held as the program sets it, since moving it would move
that tool too. A target refused because Newton stopped against a joint's limit says which joint and where.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array
from models.compensation.poses import NO_NEAR_SOLUTION, compensate_near, pose_matrices
from models.description.robot import RobotDescription
from models.engine.runtime import Registry, Runtime, default_registry
from models.errors import InvalidInput, WrongShape
from models.inverse.kkt import kkt_functions, newton_kkt
from models.inverse.problem import joint_weights
from models.kinematics import forward_kinematics
from models.tree.kinematics import tool_poses, tree_joints
from models.tree.tree import RobotTree

WIDER = np.pi / 2
"""How far past each limit (rad, mm) Newton may go when a refusal is checked for a joint out of its range."""
LIMIT_SLACK = 1e-9


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


def _shared(tree: RobotTree, tool: str, other: str) -> int:
    """How many branches the paths of `tool` and `other` share from the base."""
    shared = 0
    for mine, theirs in zip(tree.path(tool), tree.path(other), strict=False):
        if mine.name != theirs.name:
            break
        shared += 1
    return shared


def _split(tree: RobotTree, tool: str, shared_branches: int, theta: Array) -> _Split:
    """The chain of `tool` cut after its first `shared_branches` branches (held as given); InvalidInput when
    nothing of the chain is left to move."""
    chain, sel = tree.chain(tool), tree.selection(tool)
    if shared_branches >= len(tree.path(tool)) or not any(b.n_joints for b in tree.path(tool)[shared_branches:]):
        raise InvalidInput(
            f"tool {tool!r} has no joint of its own: every branch on its path also carries another tool, whose "
            "pose would move with it, so nothing is left to compensate with",
            field="tool",
            value=tool,
        )
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
    t_rel = _targets(targets, q.shape[0])
    at = tool_poses(tree, frame, q, theta, registry=registry)
    world = pose_matrices(at.positions, at.rotations) @ t_rel  # T = T_frame · T_rel
    return _compensate(tree, theta, _split(tree, tool, _shared(tree, tool, frame), theta), q, world, registry=registry)


def compensate_world(
    tree: RobotTree,
    calibrated: ArrayLike,
    tool: str,
    joints: ArrayLike,
    targets: ArrayLike,
    *,
    registry: Registry | None = None,
) -> RelativeCompensation:
    """Joints putting tool `tool` on `targets` ((N, 4, 4) poses in the tree's world, the instrument's frame, mm)
    on the tree with the `calibrated` parameters, next to the program's `joints`. Only the tool's own branches
    move: a branch that also carries another tool (a waist, a track) is held as the program sets it, since
    moving it would move that tool too."""
    registry = registry or default_registry()
    theta = tree.parameters.vector(calibrated)
    tree.tip(tool)
    q = tree_joints(tree, joints)
    world = _targets(targets, q.shape[0])
    shared = max((_shared(tree, tool, other) for other in tree.tips if other != tool), default=0)
    return _compensate(tree, theta, _split(tree, tool, shared, theta), q, world, registry=registry)


def _targets(targets: ArrayLike, n: int) -> Array:
    t = np.asarray(targets, dtype=float)
    if t.shape != (n, 4, 4) or not np.all(np.isfinite(t)):
        raise WrongShape(f"targets must be {n} finite 4 x 4 poses, one per joint vector", field="targets")
    return t


def _compensate(
    tree: RobotTree, theta: Array, split: _Split, q: Array, world: Array, *, registry: Registry
) -> RelativeCompensation:
    """Targets in the world solved on the rest of the split chain, from the given joints."""
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
    runtime = registry.runtime(split.rest)
    seeds = q[:, split.rest_joints]
    solved, reached, reasons = compensate_near(split.rest, split.rest_params, world, seeds, runtime=runtime)
    reasons = _at_a_limit(tree, split, world=world, seeds=seeds, reached=reached, reasons=reasons, runtime=runtime)
    out = q.copy()
    out[np.ix_(reached, split.rest_joints)] = solved[reached]
    return RelativeCompensation(out, tuple(int(j) for j in split.rest_joints), reached, reasons)


def _at_a_limit(
    tree: RobotTree,
    split: _Split,
    *,
    world: Array,
    seeds: Array,
    reached: NDArray[np.bool_],
    reasons: tuple[str | None, ...],
    runtime: Runtime,
) -> tuple[str | None, ...]:
    """The reasons, a refusal that Newton with every range widened by half a turn solves outside a joint's range
    saying which joint and where it would have to go: the target needs it past its limit (rather than a singular
    configuration or the edge of the reach, which stay the chain's reason)."""
    failed = np.flatnonzero(~reached & np.array([r == NO_NEAR_SOLUTION for r in reasons], dtype=bool))
    desc = split.rest
    if failed.size == 0 or desc.has_closure:
        return reasons
    t = world[failed]
    target = np.hstack([t[:, :3, 3], t[:, :3, :3].transpose(0, 2, 1).reshape(failed.size, 9)])
    lo, hi = desc.joint_min, desc.joint_max
    start = seeds[failed]
    v, converged = newton_kkt(
        kkt_functions(desc, runtime),
        start.copy(),
        target,
        seed=start,
        weights=np.broadcast_to(joint_weights(desc, None), start.shape),
        theta=split.rest_params,
        lower=lo - WIDER,
        upper=hi + WIDER,
        position_only=False,
    )
    out = list(reasons)
    for k, i in enumerate(failed):
        outside = np.flatnonzero((v[k] < lo - LIMIT_SLACK) | (v[k] > hi + LIMIT_SLACK))
        if not converged[k] or outside.size == 0:
            continue
        c = int(outside[0])
        j = int(split.rest_joints[c])
        kind, scale = tree.joint_kinds[j], tree.joint_kinds[j].to_boundary
        out[int(i)] = (
            f"out of range: the calibrated tree reaches it with joint {tree.joint_names[j]} at "
            f"{v[k, c] * scale:.6g} {kind.boundary_unit}, outside its range [{lo[c] * scale:.6g}, "
            f"{hi[c] * scale:.6g}] {kind.boundary_unit}"
        )
    return tuple(out)
