"""A hand-written numpy model of the example trees (`models.tree.examples`), independent of the models' code:
standard DH links, poses as (translation, rotation vector) through scipy's Rotation, and the global parameter
layout written out by hand. The tree tests check the models' FK, Jacobians and fits against it."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.optimize
from scipy.spatial.transform import Rotation

from models._types import Array

if TYPE_CHECKING:
    from models.tree import RobotTree, ToolRecords

Segment = tuple[str, int, int]
"""("pose", first parameter, -1) or ("dh", first parameter, global joint index)."""


def dh(theta: Array, d: Array, a: Array, alpha: Array) -> Array:
    """(N, 4, 4) Rz(θ) Tz(d) Tx(a) Rx(α)."""
    n = np.broadcast(theta, d, a, alpha).shape[0]
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    t = np.zeros((n, 4, 4))
    t[:, 0] = np.stack([ct, -st * ca, st * sa, a * ct], axis=1)
    t[:, 1] = np.stack([st, ct * ca, -ct * sa, a * st], axis=1)
    t[:, 2] = np.stack([np.zeros(n), sa * np.ones(n), ca * np.ones(n), d * np.ones(n)], axis=1)
    t[:, 3, 3] = 1.0
    return t


def pose(p: Array) -> Array:
    t = np.eye(4)
    t[:3, :3] = Rotation.from_rotvec(p[3:6]).as_matrix()
    t[:3, 3] = p[:3]
    return t


def chain_fk(segments: list[Segment], theta: Array, q: Array) -> Array:
    """(N, 4, 4) world <- tool: the product of the segments for parameters `theta` and global joints `q`."""
    t = np.broadcast_to(np.eye(4), (q.shape[0], 4, 4)).copy()
    for kind, p, j in segments:
        if kind == "pose":
            t = t @ pose(theta[p : p + 6])
        else:
            t = t @ dh(theta[p] + q[:, j], theta[p + 1], theta[p + 2], theta[p + 3])
    return t


def arm(first_param: int, first_joint: int) -> list[Segment]:
    return [("dh", first_param + 4 * k, first_joint + k) for k in range(6)]


TORSO: dict[str, list[Segment]] = {
    # base 0:6, waist 6:10, left mount 10:16, left links 16:40, right mount 40:46, right links 46:70,
    # left tool 70:76, right tool 76:82; joints: waist 0, left 1..6, right 7..12.
    "left": [("pose", 0, -1), ("dh", 6, 0), ("pose", 10, -1), *arm(16, 1), ("pose", 70, -1)],
    "right": [("pose", 0, -1), ("dh", 6, 0), ("pose", 40, -1), *arm(46, 7), ("pose", 76, -1)],
}
TORSO_NAMES = {0: "base.x", 6: "waist.link1.theta", 10: "left.mount.x", 16: "left.link1.theta", 40: "right.mount.x"}
TORSO_NAMES |= {46: "right.link1.theta", 70: "left.tool.x", 76: "right.tool.x", 81: "right.tool.rz"}

POSITIONER: dict[str, list[Segment]] = {
    # base 0:6, arm links 6:30, positioner mount 30:36, its links 36:44, arm tool 44:50, part 50:56.
    "arm": [("pose", 0, -1), *arm(6, 0), ("pose", 44, -1)],
    "positioner": [("pose", 0, -1), ("pose", 30, -1), ("dh", 36, 6), ("dh", 40, 7), ("pose", 50, -1)],
}
POSITIONER_NAMES = {30: "positioner.mount.x", 36: "positioner.link1.theta", 44: "arm.tool.x", 55: "positioner.tool.rz"}


def relative(a: Array, b: Array) -> Array:
    """(N, 4, 4) A in B's frame."""
    return np.linalg.inv(b) @ a


def tool_positions(segments: dict[str, list[Segment]], theta: Array, tool: str, frame: str | None, q: Array) -> Array:
    """(N, 3) `tool`'s positions at joints `q` for parameters `theta`: in the world, or in tool `frame`'s frame."""
    a = chain_fk(segments[tool], theta, q)
    return (a if frame is None else relative(a, chain_fk(segments[frame], theta, q)))[:, :3, 3]


def reference_fit(
    segments: dict[str, list[Segment]],
    groups: list[ToolRecords],
    start: Array,
    free: Array,
    scales: Array,
    sigma_mm: float,
) -> Array:
    """scipy's 'trf' on this model (finite-difference Jacobian) over the parameters `free` (indices, moved in
    units of their `scales`) from `start`, the position residuals weighted by `sigma_mm`: the parameters of the
    independent fit the tree calibrations are checked against."""

    def residuals(z: Array) -> Array:
        theta = start.copy()
        theta[free] += scales[free] * z
        return np.concatenate(
            [
                ((tool_positions(segments, theta, g.tool, g.frame, g.joints) - g.positions) / sigma_mm).ravel()
                for g in groups
            ]
        )

    fit = scipy.optimize.least_squares(residuals, np.zeros(free.size), method="trf", x_scale="jac", xtol=1e-12)
    theta = start.copy()
    theta[free] += scales[free] * fit.x
    return theta


def rms_error(
    segments: dict[str, list[Segment]], theta: Array, truth: Array, q: Array, tool: str, frame: str | None = None
) -> float:
    """RMS distance (mm) between `tool`'s positions at joints `q` for `theta` and for the `truth`, in the world or
    in tool `frame`'s frame."""
    error = tool_positions(segments, theta, tool, frame, q) - tool_positions(segments, truth, tool, frame, q)
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))


def pinocchio_tips(pin: Any, urdf: str, tree: RobotTree, q: Array) -> dict[str, Array]:
    """Pinocchio's reading of `urdf` (`pin`, the module): each of the tree's tips (a link of the file) at the tree's
    joints `q`, as (N, 4, 4) poses in the file's base link, translations in mm. The tree's joints are internal
    units, Pinocchio's SI: a prismatic joint's mm are its metres."""
    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    index = [model.joints[model.getJointId(name)].idx_q for name in tree.joint_names]
    to_si = np.array([1e-3 if kind.name == "LENGTH" else 1.0 for kind in tree.joint_kinds])
    out = {tip: np.tile(np.eye(4), (q.shape[0], 1, 1)) for tip in tree.tips}
    for i in range(q.shape[0]):
        configuration = pin.neutral(model)
        configuration[index] = q[i] * to_si
        pin.framesForwardKinematics(model, data, configuration)
        for tip in tree.tips:
            frame = data.oMf[model.getFrameId(tip)]
            out[tip][i, :3, :3] = frame.rotation
            out[tip][i, :3, 3] = frame.translation * 1000.0
    return out
