"""Joint vectors, poses and targets, and the forward/inverse kinematics answers."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from models import RobotDescription
from models._types import IDENTITY, Array, Pose6
from models.compensation import Compensation
from models.errors import InvalidQuaternion
from models.identification.pose_accuracy import MeasuredRegion, PoseAccuracy
from models.kinematics import ForwardResult, as_joint_array
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix, rotvec_to_matrix_np
from service.errors import BadRequest
from service.schemas.common import PosePublic, Target
from service.schemas.kinematics import (
    ForwardResponse,
    InverseResponse,
    MeasuredRegionPublic,
    PoseAccuracyPublic,
)

QUATERNION_TOLERANCE = 1e-3


def joints_in(desc: RobotDescription, rows: Sequence[Sequence[float]]) -> Array:
    """(N, n_joints) internal units (mm, rad) from boundary rows (mm, deg)."""
    # The schema bounds a vector's length (1…70); the robot's own length is checked here (a 422 naming it).
    return as_joint_array(desc, rows) / desc.joint_to_boundary


def joints_out(desc: RobotDescription, joints: Array) -> list[list[float]]:
    rows: list[list[float]] = (np.asarray(joints) * desc.joint_to_boundary).tolist()
    return rows


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


def pose6_out(pose: Sequence[float]) -> PosePublic:
    q = matrix_to_quaternion(rotvec_to_matrix_np(np.asarray(pose[3:], dtype=float))[None])[0]
    return PosePublic(position=[float(v) for v in pose[:3]], orientation=q.tolist())


def targets_in(targets: Sequence[Target]) -> tuple[Array, Array | None]:
    """(N, 3) positions and (N, 4) quaternions, or None when every target is position-only."""
    with_orientation = [t.orientation is not None for t in targets]
    if any(with_orientation) and not all(with_orientation):
        first = with_orientation.index(not with_orientation[0])
        raise BadRequest(
            f"target {first}: give an orientation for every target or for none (position only)", record=first
        )
    positions = np.array([t.position for t in targets], dtype=float)
    if not all(with_orientation):
        return positions, None
    return positions, np.array([t.orientation for t in targets], dtype=float)


def frames_out(names: Sequence[str], frames: Array) -> list[dict[str, dict[str, list[float]]]]:
    """(N, F, 4, 4) world <- frame as, per joint vector, each frame's position (mm) and quaternion by name."""
    n, count = frames.shape[:2]
    quats = matrix_to_quaternion(frames[:, :, :3, :3].reshape(-1, 3, 3)).reshape(n, count, 4).tolist()
    positions = frames[:, :, :3, 3].tolist()
    return [
        {name: {"position": p, "orientation": q} for name, p, q in zip(names, ps, qs, strict=True)}
        for ps, qs in zip(positions, quats, strict=True)
    ]


def forward_out(
    fk: ForwardResult,
    warnings: list[str] | None = None,
    frames: list[dict[str, dict[str, list[float]]]] | None = None,
) -> ForwardResponse:
    quats = matrix_to_quaternion(fk.rotations)
    # One validation call over plain lists: 2.3 ms for 1 000 poses here (1.4 ms of it the quaternions); building
    # PosePublic one by one was ~10 % slower.
    return ForwardResponse.model_validate(
        {
            "poses": [
                {"position": p, "orientation": q} for p, q in zip(fk.positions.tolist(), quats.tolist(), strict=True)
            ],
            "warnings": warnings or [],
            "frames": frames,
        }
    )


def accuracy_out(found: PoseAccuracy, region: MeasuredRegion, calibration_id: str, version: int) -> dict[str, Any]:
    """The `accuracy` and `measured_region` of a forward answer (orientations in degrees)."""
    return {
        "accuracy": [
            PoseAccuracyPublic(
                position_mm=float(p),
                orientation_deg=math.degrees(float(r)),
                distance_to_measured=float(d),
                in_measured_region=why is None,
                extrapolation=why,
            )
            for p, r, d, why in zip(
                found.position_mm, found.orientation_rad, found.distance, found.extrapolation, strict=True
            )
        ],
        "measured_region": MeasuredRegionPublic(
            calibration_id=calibration_id,
            version=version,
            poses=int(region.joints.shape[0]),
            rms_position_mm=region.rms_position_mm,
            max_position_mm=region.max_position_mm,
            widest_gap=region.widest_gap,
        ),
    }


def inverse_out(desc: RobotDescription, answer: Compensation) -> InverseResponse:
    quats = matrix_to_quaternion(answer.rotations)
    orientation = None if answer.orientation_error_rad is None else np.degrees(answer.orientation_error_rad).tolist()
    return InverseResponse.model_validate(
        {
            "joints": joints_out(desc, answer.joints),
            "position_error_mm": answer.position_error_mm.tolist(),
            "orientation_error_deg": orientation,
            "reachable": answer.reachable.tolist(),
            "reasons": list(answer.reasons),
            "reached_poses": [
                {"position": p, "orientation": q}
                for p, q in zip(answer.positions.tolist(), quats.tolist(), strict=True)
            ],
            "hexapod_condition": answer.condition.tolist(),
            "methods": list(answer.methods),
            "seconds": answer.seconds,
        }
    )
