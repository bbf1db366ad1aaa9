"""Forward kinematics of a tree's tools, absolute and relative, with their Jacobians wrt the GLOBAL parameters.

A tool's pose is its chain's (`RobotTree.chain`), computed by the existing compiled Functions of that chain's
structure; its Jacobian is the chain's, scattered into the global columns by `RobotTree.selection`, so a
parameter of a shared stage (a waist) gathers the columns of every chain through it. Rows are (dp; dω): the
position's change and the small rotation, both in the frame the pose is expressed in.

Relative kinematics is tool A in tool B's frame (the torch in the part's frame on a positioner, one hand in
the other's): p = R_Bᵀ (p_A − p_B), R = R_Bᵀ R_A, and with world-frame rows (dp_A, ω_A), (dp_B, ω_B) of both
tools, dp = R_Bᵀ (dp_A − dp_B + (p_A − p_B) × ω_B) and ω = R_Bᵀ (ω_A − ω_B) (differentiating R_Bᵀ gives
−R_Bᵀ [ω_B]×). The base cancels: a relative pose does not depend on where the instrument stands.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.engine.runtime import Registry, default_registry
from models.kinematics import JOINT_RANGE_SLACK, forward_kinematics, joint_vectors, refuse_out_of_range
from models.tree.tree import RobotTree


@dataclass(frozen=True)
class TreePoses:
    """Poses of one tool (or of one tool in another's frame) for a batch of global joint vectors."""

    positions: Array
    """(N, 3) mm."""
    rotations: Array
    """(N, 3, 3)."""
    jacobians: Array | None
    """(N, 6, n_params) rows (dp; dω) wrt the tree's global parameters; None unless asked for."""


def tree_joints(tree: RobotTree, joints: ArrayLike, *, check_ranges: bool = True) -> Array:
    """Global joint vectors as an (N, n_joints) array: shape, finiteness and (optionally) ranges checked, each
    refusal naming the pose and the tree's joint."""
    q = joint_vectors(joints, tree.joint_names, of=" of the tree")
    if check_ranges:
        lo, hi = tree.joint_limits
        refuse_out_of_range(q, lo, hi, slack=JOINT_RANGE_SLACK, names=tree.joint_names, kinds=tree.joint_kinds)
    return q


def tool_poses(
    tree: RobotTree,
    tool: str,
    joints: ArrayLike,
    params: ArrayLike | None = None,
    *,
    jacobian: bool = False,
    check_ranges: bool = True,
    registry: Registry | None = None,
) -> TreePoses:
    """Tool `tool` in the tree's world frame (the instrument's) at global joints and parameters."""
    chain, sel = tree.chain(tool), tree.selection(tool)
    theta = tree.parameters.nominal if params is None else tree.parameters.vector(params)
    q = tree_joints(tree, joints, check_ranges=check_ranges)
    runtime = (registry or default_registry()).runtime(chain)
    q_chain, theta_chain = q[:, sel.joints], theta[sel.params]
    if not jacobian:
        fk = forward_kinematics(chain, q_chain, theta_chain, check_ranges=False, runtime=runtime)
        return TreePoses(fk.positions, fk.rotations, None)
    fkj = forward_kinematics(chain, q_chain, theta_chain, jacobian=True, check_ranges=False, runtime=runtime)
    full = np.zeros((q.shape[0], 6, tree.n_params))
    full[:, :, sel.params] = fkj.jacobians  # each chain parameter is a different global one: no sums lost
    return TreePoses(fkj.positions, fkj.rotations, full)


def relative_poses(
    tree: RobotTree,
    tool: str,
    frame: str,
    joints: ArrayLike,
    params: ArrayLike | None = None,
    *,
    jacobian: bool = False,
    check_ranges: bool = True,
    registry: Registry | None = None,
) -> TreePoses:
    """Tool `tool` in the frame of tool `frame` (see the module docstring), with its Jacobian if asked."""
    a = tool_poses(tree, tool, joints, params, jacobian=jacobian, check_ranges=check_ranges, registry=registry)
    b = tool_poses(tree, frame, joints, params, jacobian=jacobian, check_ranges=False, registry=registry)
    return relative_of(a, b)


def relative_of(a: TreePoses, b: TreePoses) -> TreePoses:
    """A's pose in B's frame, from both in one frame (with Jacobians when both have them)."""
    rb_t = np.swapaxes(b.rotations, 1, 2)
    gap = a.positions - b.positions
    positions = np.einsum("nij,nj->ni", rb_t, gap)
    rotations = rb_t @ a.rotations
    if a.jacobians is None or b.jacobians is None:
        return TreePoses(positions, rotations, None)
    ja, jb = a.jacobians, b.jacobians
    omega_b = jb[:, 3:, :]
    dp = ja[:, :3, :] - jb[:, :3, :] + np.cross(gap[:, :, None], omega_b, axis=1)
    rows = np.concatenate([dp, ja[:, 3:, :] - omega_b], axis=1)
    # Both blocks rotate into B's frame: R_Bᵀ applied to each 3-row half.
    jac = np.concatenate([rb_t @ rows[:, :3, :], rb_t @ rows[:, 3:, :]], axis=1)
    return TreePoses(positions, rotations, jac)
