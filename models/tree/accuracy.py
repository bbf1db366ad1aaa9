"""What a tree's calibration predicts: each tool's accuracy in the instrument's frame, and the RELATIVE accuracy
of one tool in another's frame (the torch to the part, one hand to the other), which is what a cell's process
needs and no single chain's calibration gives.

First order, as the chain's (`models.identification.statistics.tcp_accuracy`): the estimated parameters'
covariance through each pose's Jacobian, the relative one through the relative Jacobian (`relative_of`), over
random joint vectors of the whole tree (one seed: results are comparable)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.engine.runtime import Registry
from models.errors import InvalidInput
from models.identification.statistics import tcp_accuracy
from models.tree.identification import TreeFit
from models.tree.kinematics import relative_of, relative_poses, tool_poses
from models.tree.tree import RobotTree
from models.workspace import usable_draws

ACCURACY_SEED = 20_470_001


@dataclass(frozen=True)
class ToolAccuracy:
    """One tool's (or one tool-in-tool's) predicted 1-σ error over the poses, mm and rad."""

    label: str
    """The tool (`left`), or the tool in the other's frame (`left/right`)."""
    rms_position_mm: float
    max_position_mm: float
    rms_orientation_rad: float


def tree_joint_samples(
    tree: RobotTree,
    n: int,
    seed: int,
    margin: float = 0.05,
    *,
    within: tuple[Array, Array] | None = None,
    params: Array | None = None,
) -> Array:
    """(n, n_joints) joint vectors uniform inside each joint's range less `margin` of it at either end (or
    uniform inside `within`, (lo, hi) internal units, as given).

    A stage closed by unknowns (a hexapod: its legs do not move independently, the platform's pose follows from
    them by closure) has its legs drawn as the chain's `models.workspace.sample_workspace` draws them instead:
    its platform uniform in the stage's workspace, the legs by the stage's inverse kinematics at `params` (the
    tree's nominal by default), and draws where a stage is not usable (a leg out of its stroke, near a
    singularity) drawn again. Uniform leg lengths would mostly not assemble. A tree without such a stage gets
    exactly the one uniform draw: its results stay comparable with earlier ones of the same seed."""
    if within is None:
        lo, hi = tree.joint_limits
        pad = margin * (hi - lo)
        lo, hi = lo + pad, hi - pad
    else:
        lo, hi = within
    rng = np.random.default_rng(seed)
    closed = [
        (stage, tree.stage_params(branch.name, k), tree.stage_joints(branch.name, k))
        for branch in tree.branches
        for k, stage in enumerate(branch.own_stages)
        if stage.n_unknowns
    ]
    if not closed:
        return rng.uniform(lo, hi, size=(n, tree.n_joints))
    theta = tree.parameters.nominal if params is None else params

    def draw(m: int) -> tuple[NDArray[np.bool_], tuple[Array, ...]]:
        q = rng.uniform(lo, hi, size=(m, tree.n_joints))
        ok = np.ones(m, dtype=bool)
        for stage, p, j in closed:
            x_lo, x_hi = stage.unknown_limits()
            x = rng.uniform(x_lo, x_hi, size=(m, x_lo.size))
            q[:, j] = stage.joints_of_unknowns(x, theta[p])
            ok &= stage.usable(q[:, j], x, theta[p])
        return ok, (q,)

    drawn = usable_draws(n, draw, (tree.n_joints,))
    if drawn is None:
        raise InvalidInput(
            "the tree's closed stages (hexapods) admit almost no pose in their workspace: check strokes and ranges",
            field="workspace",
        )
    return drawn[0]


def tree_accuracy(
    tree: RobotTree,
    fit: TreeFit,
    *,
    relative: Sequence[tuple[str, str]] = (),
    samples: int = 200,
    joints: Array | None = None,
    registry: Registry | None = None,
) -> tuple[ToolAccuracy, ...]:
    """Every tool's predicted accuracy, then each (tool, frame) pair's relative one, over `joints` (default:
    `samples` random joint vectors of the tree)."""
    return predicted_accuracy(
        tree,
        fit.parameters,
        fit.estimated,
        fit.parameter_covariance,
        relative=relative,
        samples=samples,
        joints=joints,
        registry=registry,
    )


def predicted_accuracy(
    tree: RobotTree,
    params: Array,
    estimated: Sequence[int],
    parameter_covariance: Array,
    *,
    relative: Sequence[tuple[str, str]] = (),
    samples: int = 200,
    joints: Array | None = None,
    registry: Registry | None = None,
) -> tuple[ToolAccuracy, ...]:
    """`tree_accuracy` of any covariance of the `estimated` global parameters (internal units, their order): a
    fit's, or the one a pose design predicts before anything is measured (`optimal_design.tree`)."""
    q = tree_joint_samples(tree, samples, ACCURACY_SEED) if joints is None else joints
    profiles = accuracy_profiles(tree, params, estimated, parameter_covariance, q, relative=relative, registry=registry)
    return tuple(
        ToolAccuracy(label, float(np.sqrt(np.mean(pos**2))), float(pos.max()), float(np.sqrt(np.mean(rot**2))))
        for label, (pos, rot) in profiles.items()
    )


def accuracy_profiles(
    tree: RobotTree,
    params: Array,
    estimated: Sequence[int],
    parameter_covariance: Array,
    joints: Array,
    *,
    relative: Sequence[tuple[str, str]] = (),
    registry: Registry | None = None,
) -> dict[str, tuple[Array, Array]]:
    """Per label (each tool, then each `tool/frame` pair): the predicted 1-σ position (mm) and orientation (rad)
    error at each of `joints`, (N,) each: what `predicted_accuracy` summarises, and what a report plots."""
    free = np.array(estimated, dtype=np.intp)
    poses = {
        tip: tool_poses(tree, tip, joints, params, jacobian=True, check_ranges=False, registry=registry)
        for tip in tree.tips
    }
    out = {tip: _profile(pose.jacobians, free, parameter_covariance) for tip, pose in poses.items()}
    for tool, frame in relative:
        rel = relative_of(poses[tree.tip(tool).name], poses[tree.tip(frame, "frame").name])
        out[f"{tool}/{frame}"] = _profile(rel.jacobians, free, parameter_covariance)
    return out


def relative_changes(
    tree: RobotTree,
    before: Array,
    after: Array,
    joints: Array,
    pairs: Sequence[tuple[str, str]],
    *,
    registry: Registry | None = None,
) -> dict[str, Array]:
    """Per `tool/frame` pair: how far the calibration moved tool's position in frame's frame at each of `joints`
    (mm, (N,)): |p(after) − p(before)|, the relative error the tree had at `before` as the calibration sees it."""
    out = {}
    for tool, frame in pairs:
        moved = [
            relative_poses(tree, tool, frame, joints, theta, check_ranges=False, registry=registry).positions
            for theta in (before, after)
        ]
        out[f"{tool}/{frame}"] = np.linalg.norm(moved[1] - moved[0], axis=1)
    return out


def _profile(jacobians: Array | None, free: NDArray[np.intp], cov: Array) -> tuple[Array, Array]:
    assert jacobians is not None
    pos, rot = tcp_accuracy(jacobians[:, :, free], cov)
    return np.asarray(pos, dtype=float), np.asarray(rot, dtype=float)
