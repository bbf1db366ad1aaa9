"""Records of a tree's tools, and their residuals with exact derivatives wrt the global parameters.

A group of records measures one tool: in the instrument's frame (a tracker on that tool: `frame` None; the
tree's base is the instrument <- base transform, as a chain's is), or in another tool's frame (`frame` names it:
the torch measured on the part held by the positioner, one hand by a camera on the other). Position rows
p_model − p_measured, then, for records with orientations, the rotation vector φ = log(R_model R_measuredᵀ), whose
derivative wrt a small rotation ω of R_model (left, in the same frame) is J_l(φ)⁻¹ ω: exact, not the
first-order ω alone, so the fit's optimum is the one an independent least-squares solver finds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.engine.runtime import Registry
from models.errors import InvalidInput, WrongShape
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np, quaternion_to_matrix
from models.tree.kinematics import TreePoses, relative_poses, tool_poses, tree_joints
from models.tree.tree import RobotTree


@dataclass(frozen=True)
class ToolRecords:
    """One tool's records: global joints, what was measured, in the instrument's frame or another tool's."""

    tool: str
    joints: Array
    """(N, n_joints) the tree's global joints, mm and rad."""
    positions: Array
    """(N, 3) mm: the tool's position in the instrument's frame (`frame` None) or in tool `frame`'s."""
    quaternions: Array | None = None
    """(N, 4) `[w, x, y, z]` its orientation in the same frame; None: positions only."""
    frame: str | None = None
    """The tool whose frame the records are in; None: the instrument's."""
    sigma_mm: float | None = None
    """This group's position σ (a camera on a hand is not a tracker); None: the noise model's."""

    @property
    def size(self) -> int:
        return int(self.joints.shape[0])

    @property
    def rows(self) -> int:
        return 3 if self.quaternions is None else 6

    @property
    def label(self) -> str:
        return self.tool if self.frame is None else f"{self.tool}/{self.frame}"

    def weights(self, noise: NoiseModel) -> Array:
        sigma = noise.position_mm if self.sigma_mm is None else self.sigma_mm
        return np.array([1.0 / sigma] * 3 + [1.0 / noise.orientation_rad] * 3)[: self.rows]

    def checked(self, tree: RobotTree, where: str) -> ToolRecords:
        """These records with their joints checked against the tree and shapes against each other."""
        tree.check_record(self.tool, self.frame, where)
        q = tree_joints(tree, self.joints)
        n = q.shape[0]
        if np.shape(self.positions) != (n, 3) or not np.all(np.isfinite(self.positions)):
            raise WrongShape(f"{where}.positions must be {n} finite (x, y, z) rows", field=f"{where}.positions")
        if self.quaternions is not None and np.shape(self.quaternions) != (n, 4):
            raise WrongShape(f"{where}.quaternions must be {n} rows [w, x, y, z]", field=f"{where}.quaternions")
        if self.sigma_mm is not None and not self.sigma_mm > 0:
            raise InvalidInput(f"{where}.sigma_mm must be a positive number of mm", field=f"{where}.sigma_mm")
        return ToolRecords(self.tool, q, np.asarray(self.positions, float), self.quaternions, self.frame, self.sigma_mm)

    def model(self, tree: RobotTree, theta: Array, registry: Registry, *, jacobian: bool = True) -> TreePoses:
        """The model's poses of these records (in their frame), with Jacobians wrt the global parameters."""
        if self.frame is None:
            return tool_poses(
                tree, self.tool, self.joints, theta, jacobian=jacobian, check_ranges=False, registry=registry
            )
        return relative_poses(
            tree, self.tool, self.frame, self.joints, theta, jacobian=jacobian, check_ranges=False, registry=registry
        )

    def residuals(self, poses: TreePoses) -> tuple[Array, Array | None]:
        """(N, rows) unweighted residuals (mm, rad) and their (N, rows, n_params) Jacobian when `poses` has one."""
        r_pos = poses.positions - self.positions
        if self.quaternions is None:
            return r_pos, None if poses.jacobians is None else poses.jacobians[:, :3, :]
        measured = quaternion_to_matrix(self.quaternions)
        phi = matrix_to_rotvec_np(poses.rotations @ np.swapaxes(measured, 1, 2))
        res = np.concatenate([r_pos, phi], axis=1)
        if poses.jacobians is None:
            return res, None
        rot = np.einsum("nij,njk->nik", left_jacobian_inverse(phi), poses.jacobians[:, 3:, :])
        return res, np.concatenate([poses.jacobians[:, :3, :], rot], axis=1)


def left_jacobian_inverse(phi: Array) -> Array:
    """(N, 3, 3) J_l(φ)⁻¹ = I − ½[φ]× + (1/θ² − (1 + cos θ)/(2 θ sin θ)) [φ]×² (its series below 1e-4 rad)."""
    theta = np.linalg.norm(phi, axis=1)
    k = np.zeros((phi.shape[0], 3, 3))
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -phi[:, 2], phi[:, 1], -phi[:, 0]
    k -= np.swapaxes(k, 1, 2)
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    coef = np.where(small, 1.0 / 12.0 + theta**2 / 720.0, 1.0 / t**2 - (1 + np.cos(t)) / (2 * t * np.sin(t)))
    out: Array = np.eye(3)[None] - 0.5 * k + coef[:, None, None] * (k @ k)
    return out
