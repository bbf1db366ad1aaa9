"""Inverse-kinematics inputs, validated: targets (per-target problems become reasons), seeds, weights."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.campaign import QUATERNION_NORM_TOLERANCE
from models.description.robot import RobotDescription
from models.errors import WrongShape
from models.inverse.routing import joints_of
from models.kinematics import as_joint_array, check_joint_ranges
from models.transforms import quaternion_to_matrix


def default_seed(desc: RobotDescription) -> Array:
    """Mid-range serial joints and the legs of each parallel stage's home pose (nominal geometry)."""
    n = desc.n_chain
    mid = (desc.joint_min[:n] + desc.joint_max[:n]) / 2
    if not desc.has_closure:
        return mid
    home = np.asarray(desc.platform_home, dtype=float)[None, :]
    return np.asarray(joints_of(desc, desc.parameters.nominal, np.c_[mid[None, :], home])[0], dtype=float)


def validated_targets(
    positions: ArrayLike, quaternions: ArrayLike | None
) -> tuple[Array, Array | None, list[str | None]]:
    """Validated targets; per-target problems become reasons instead of exceptions."""
    p = np.array(positions, dtype=float)
    if p.ndim == 1:
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise WrongShape(
            f"target positions must be N × 3 numbers (mm), got shape {p.shape}",
            field="positions",
            expected=[-1, 3],
            got=list(p.shape),
        )
    reasons: list[str | None] = [None] * p.shape[0]
    for i in (int(k) for k in np.flatnonzero(~np.isfinite(p).all(axis=1))):
        reasons[i] = f"target {i}: position {p[i].tolist()} is not finite"
    if quaternions is None:
        return p, None, reasons
    q = np.array(quaternions, dtype=float)
    if q.ndim == 1:
        q = q[None, :]
    if q.shape != (p.shape[0], 4):
        raise WrongShape(
            f"expected {p.shape[0]} orientations of 4 numbers [w, x, y, z], got shape {q.shape}",
            field="quaternions",
            expected=[p.shape[0], 4],
            got=list(q.shape),
        )
    norms = np.linalg.norm(q, axis=1)
    for i in range(q.shape[0]):
        if not np.isfinite(q[i]).all():
            reasons[i] = reasons[i] or f"target {i}: orientation {q[i].tolist()} is not finite"
        elif abs(norms[i] - 1) > QUATERNION_NORM_TOLERANCE:
            reasons[i] = reasons[i] or (
                f"target {i}: orientation quaternion has norm {norms[i]:.6g}; a unit quaternion [w, x, y, z] is "
                f"required (norms within {QUATERNION_NORM_TOLERANCE} of 1 are normalised)"
            )
    ok = np.array([r is None for r in reasons])
    unit = np.tile([1.0, 0, 0, 0], (q.shape[0], 1))
    unit[ok] = q[ok] / norms[ok, None]
    return p, quaternion_to_matrix(unit), reasons


def seeds_for(desc: RobotDescription, seed: ArrayLike | None, n: int) -> Array:
    if seed is None:
        return np.tile(default_seed(desc), (n, 1))
    s = as_joint_array(desc, seed)
    if s.shape[0] not in (1, n):
        raise WrongShape(
            f"give one seed or one per target ({n}), got {s.shape[0]}",
            field="seed",
            expected=[n, desc.n_joints],
            got=list(s.shape),
        )
    check_joint_ranges(desc, s)
    return np.broadcast_to(s, (n, desc.n_joints)).copy()
