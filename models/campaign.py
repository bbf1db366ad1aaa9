"""A measurement campaign: joint readings and what the instrument saw, validated.

Internal units: joints in mm / rad, positions in mm (instrument frame),
orientations as unit quaternions `[w, x, y, z]` or absent (position-only
instrument, e.g. a laser tracker with one reflector).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.errors import InvalidInput, InvalidQuaternion, NonFiniteValue, WrongShape
from models.kinematics import as_joint_array, check_joint_ranges
from models.measurement import MeasurementKind
from models.robot import RobotDescription
from models.transforms import quaternion_to_matrix

QUATERNION_NORM_TOLERANCE = 1e-3
"""Quaternions whose norm is within this of 1 are normalised; others are rejected."""


@dataclass(frozen=True)
class Campaign:
    joints: Array
    """(N, n_joints), mm and rad."""
    positions: Array
    """(N, 3) measured TCP positions, mm, instrument frame."""
    quaternions: Array | None = None
    """(N, 4) measured TCP orientations `[w, x, y, z]`, unit norm; None for position-only data."""

    @property
    def size(self) -> int:
        return int(self.joints.shape[0])

    @property
    def kind(self) -> MeasurementKind:
        return MeasurementKind.POSITION if self.quaternions is None else MeasurementKind.POSE

    @property
    def position_only(self) -> bool:
        return self.quaternions is None

    @property
    def rotations(self) -> Array:
        if self.quaternions is None:
            raise InvalidInput("a position-only campaign has no orientations", field="quaternions")
        return quaternion_to_matrix(self.quaternions)

    def subset(self, index: ArrayLike) -> Campaign:
        idx = np.asarray(index)
        quats = None if self.quaternions is None else self.quaternions[idx]
        return Campaign(self.joints[idx], self.positions[idx], quats)


def make_campaign(
    desc: RobotDescription,
    joints: ArrayLike,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    *,
    check_ranges: bool = True,
) -> Campaign:
    """Validate raw arrays (internal units) into a Campaign; domain errors name the offending record."""
    q = as_joint_array(desc, joints)
    if check_ranges:
        check_joint_ranges(desc, q)
    p = np.array(positions, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.shape != (q.shape[0], 3):
        raise WrongShape(
            f"expected {q.shape[0]} positions of 3 numbers, got shape {p.shape}",
            field="positions",
            expected=[q.shape[0], 3],
            got=list(p.shape),
        )
    _check_finite(p, "position")
    if quaternions is None:
        return Campaign(q, p, None)
    quat = np.array(quaternions, dtype=float)
    if quat.ndim == 1:
        quat = quat[None, :]
    if quat.shape != (q.shape[0], 4):
        raise WrongShape(
            f"expected {q.shape[0]} orientations of 4 numbers [w, x, y, z], got shape {quat.shape}",
            field="quaternions",
            expected=[q.shape[0], 4],
            got=list(quat.shape),
        )
    _check_finite(quat, "orientation")
    norms = np.linalg.norm(quat, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_NORM_TOLERANCE)
    if bad.size:
        i = int(bad[0])
        raise InvalidQuaternion(
            f"record {i}: orientation quaternion has norm {norms[i]:.6g}; a unit quaternion [w, x, y, z] is "
            f"required (norms within {QUATERNION_NORM_TOLERANCE} of 1 are normalised)",
            pose=i,
            norm=float(norms[i]),
            count=int(bad.size),
        )
    return Campaign(q, p, quat / norms[:, None])


def _check_finite(a: Array, what: str) -> None:
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        i = int(bad[0][0])
        raise NonFiniteValue(f"record {i}: {what} contains {a[i].tolist()}, not finite numbers", pose=i)
