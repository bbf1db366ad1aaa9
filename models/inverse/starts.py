"""Starting points for inverse kinematics: the nearest of a few thousand reachable poses (k-d trees).

A table belongs to one parameter vector (the calibrated robot's); the runtime keeps the most recent ones.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.kinematics import pose_batch
from models.workspace import sample_workspace

TABLE_POSES = 4000
TABLE_SEED = 17
TABLES_KEPT = 8
"""Start tables kept per runtime: one per calibrated parameter vector in use."""
ORIENTATION_FEATURE_MM = 300.0
"""How far apart, in the k-d tree, two poses a radian apart look (about the tool's lever arm)."""


class StartTable:
    """Reachable poses of one parameter vector, for starting points."""

    def __init__(self, desc: RobotDescription, theta: Array, runtime: Runtime) -> None:
        joints, platforms = sample_workspace(desc, TABLE_POSES, seed=TABLE_SEED, return_platforms=True, runtime=runtime)
        fk = pose_batch(desc, joints, theta, platforms, runtime=runtime)
        self.start = np.hstack([joints[:, : desc.n_chain], platforms[:, : desc.n_ik - desc.n_chain]])
        self.positions, self.rotations = fk.positions, fk.rotations
        """The TCP pose of each start (mm; rotation matrices), where a homotopy from it begins."""
        self.pose_tree = cKDTree(features(fk.positions, fk.rotations))
        self.position_tree = cKDTree(fk.positions)

    def nearest_k_index(self, target: Array, k: int, *, position_only: bool) -> NDArray[np.intp]:
        """Table rows (N, k) of the k nearest starting points for targets (N, 12), nearest first."""
        n = target.shape[0]
        if position_only:
            _, nearest = self.position_tree.query(target[:, :3], k=k)
        else:
            rot = target[:, 3:].reshape(n, 3, 3).transpose(0, 2, 1)
            _, nearest = self.pose_tree.query(features(target[:, :3], rot), k=k)
        return np.asarray(nearest, dtype=np.intp).reshape(n, k)

    def nearest_k(self, target: Array, k: int, *, position_only: bool) -> Array:
        """The k nearest starting points (N, k, n_v) for targets (N, 12), nearest first."""
        return np.asarray(self.start[self.nearest_k_index(target, k, position_only=position_only)])

    def nearest(self, target: Array, *, position_only: bool) -> Array:
        """Starting points [carriage joints, platform pose] (N, n_chain + 6) for targets (N, 12)."""
        n = target.shape[0]
        if position_only:
            _, nearest = self.position_tree.query(target[:, :3])
        else:
            rot = target[:, 3:].reshape(n, 3, 3).transpose(0, 2, 1)
            _, nearest = self.pose_tree.query(features(target[:, :3], rot))
        return np.asarray(self.start[nearest])


def start_table(desc: RobotDescription, theta: Array, runtime: Runtime | None = None) -> StartTable:
    rt = runtime_for(desc, runtime)
    # The samples depend on the description's ranges and workspace, the poses on theta.
    key = (desc, theta.tobytes())
    return rt.artefact("start_table", key, lambda: StartTable(desc, theta, rt), capacity=TABLES_KEPT)


def features(positions: Array, rotations: Array) -> Array:
    return np.hstack(
        [positions, ORIENTATION_FEATURE_MM * rotations[:, :, 0], ORIENTATION_FEATURE_MM * rotations[:, :, 1]]
    )
