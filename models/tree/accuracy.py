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
from models.identification.statistics import tcp_accuracy
from models.runtime import Registry
from models.tree.identification import TreeFit
from models.tree.kinematics import relative_of, tool_poses
from models.tree.tree import RobotTree

ACCURACY_SEED = 20_470_001


@dataclass(frozen=True)
class ToolAccuracy:
    """One tool's (or one tool-in-tool's) predicted 1-σ error over the poses, mm and rad."""

    label: str
    """The tool (`left`), or the tool in the other's frame (`left/right`)."""
    rms_position_mm: float
    max_position_mm: float
    rms_orientation_rad: float


def tree_joint_samples(tree: RobotTree, n: int, seed: int, margin: float = 0.05) -> Array:
    """(n, n_joints) joint vectors uniform inside each joint's range less `margin` of it at either end."""
    lo, hi = tree.joint_limits
    pad = margin * (hi - lo)
    return np.random.default_rng(seed).uniform(lo + pad, hi - pad, size=(n, tree.n_joints))


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
    free = np.array(estimated, dtype=np.intp)
    poses = {
        tip: tool_poses(tree, tip, q, params, jacobian=True, check_ranges=False, registry=registry) for tip in tree.tips
    }
    out = []
    for tip, pose in poses.items():
        out.append(_accuracy(tip, pose.jacobians, free, parameter_covariance))
    for tool, frame in relative:
        rel = relative_of(poses[tree.tip(tool).name], poses[tree.tip(frame, "frame").name])
        out.append(_accuracy(f"{tool}/{frame}", rel.jacobians, free, parameter_covariance))
    return tuple(out)


def _accuracy(label: str, jacobians: Array | None, free: NDArray[np.intp], cov: Array) -> ToolAccuracy:
    assert jacobians is not None
    pos, rot = tcp_accuracy(jacobians[:, :, free], cov)
    return ToolAccuracy(
        label,
        float(np.sqrt(np.mean(pos**2))),
        float(pos.max()),
        float(np.sqrt(np.mean(rot**2))),
    )
