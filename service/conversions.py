"""The only place where boundary units (mm, degrees, quaternions) meet internal ones (mm, radians).

Joint vectors `[q1, q2, q3, q4, l1…l6]` are mm and degrees outside, mm and radians inside; orientations are
unit quaternions `[w, x, y, z]` outside and rotation vectors or matrices inside.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from models import RobotDescription
from models._types import IDENTITY, Pose6
from models.errors import InvalidQuaternion
from models.kinematics import Array
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix

QUATERNION_TOLERANCE = 1e-3


def joints_in(desc: RobotDescription, rows: Sequence[Sequence[float]]) -> Array:
    return np.asarray(rows, dtype=float).reshape(-1, desc.n_joints) / desc.joint_to_boundary


def joints_out(desc: RobotDescription, joints: Array) -> list[list[float | None]]:
    out = np.asarray(joints) * desc.joint_to_boundary
    return [[float(v) if np.isfinite(v) else None for v in row] for row in out]


def unit_quaternion(q: Sequence[float], what: str) -> Array:
    arr = np.asarray(q, dtype=float)
    # Components beyond ±2 cannot belong to a near-unit quaternion, and squaring 1e154 would overflow.
    norm = float(np.linalg.norm(arr)) if np.all(np.abs(arr) <= 2.0) else float("inf")
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        raise InvalidQuaternion(
            f"{what}: orientation quaternion has norm {norm:.6g}; a unit quaternion [w, x, y, z] is required",
            norm=norm,
        )
    return arr / norm


def pose6_in(position: Sequence[float] | None, orientation: Sequence[float] | None, what: str) -> Pose6:
    """A boundary Pose (mm, quaternion) as the description's (x, y, z, rotation vector in rad)."""
    if position is None and orientation is None:
        return IDENTITY
    p = np.zeros(3) if position is None else np.asarray(position, dtype=float)
    q = np.array([1.0, 0, 0, 0]) if orientation is None else unit_quaternion(orientation, what)
    r = matrix_to_rotvec_np(quaternion_to_matrix(q[None, :]))[0]
    return (float(p[0]), float(p[1]), float(p[2]), float(r[0]), float(r[1]), float(r[2]))


def pose6_out(pose: Sequence[float]) -> dict[str, list[float]]:
    from models.transforms import rotvec_to_matrix_np

    q = matrix_to_quaternion(rotvec_to_matrix_np(np.asarray(pose[3:]))[None])[0]
    return {"position": [float(v) for v in pose[:3]], "orientation": [float(v) for v in q]}


def poses_out(positions: Array, rotations: Array) -> list[dict[str, list[float]]]:
    quats = matrix_to_quaternion(rotations)
    return [
        {"position": [float(v) for v in p], "orientation": [float(v) for v in q]}
        for p, q in zip(positions, quats, strict=True)
    ]


def degrees(radians: float) -> float:
    return float(np.degrees(radians))


def radians(degrees_: float) -> float:
    return float(np.radians(degrees_))
