"""Rigid transforms, symbolic (CasADi SX/MX) and numeric (numpy).

Conventions (spec `iwr-model.md`): millimetres and radians inside; rotation
matrices map child-frame vectors into the parent frame; quaternions are
`[w, x, y, z]` (Hamilton); a "rotation vector" is axis * angle.

The symbolic rotation-vector maps are written in terms of the squared angle so
that they, and their derivatives, are exact at the identity (the nominal base
and tool), where `|v|` itself is not differentiable.
"""

from __future__ import annotations

from typing import TypeVar

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike, NDArray

Sym = TypeVar("Sym", ca.SX, ca.MX)

# Below this squared angle (rad²) the Taylor series replaces the closed forms.
_SMALL_ANGLE_SQ = 1e-8


def rot_x(angle: Sym) -> Sym:
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(ca.horzcat(1, 0, 0), ca.horzcat(0, c, -s), ca.horzcat(0, s, c))


def rot_y(angle: Sym) -> Sym:
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(ca.horzcat(c, 0, s), ca.horzcat(0, 1, 0), ca.horzcat(-s, 0, c))


def rot_z(angle: Sym) -> Sym:
    c, s = ca.cos(angle), ca.sin(angle)
    return ca.vertcat(ca.horzcat(c, -s, 0), ca.horzcat(s, c, 0), ca.horzcat(0, 0, 1))


def homogeneous(rotation: Sym, translation: Sym) -> Sym:
    """4x4 transform from a 3x3 rotation and a 3-vector."""
    top = ca.horzcat(rotation, translation)
    return ca.vertcat(top, ca.horzcat(0, 0, 0, 1))


def skew(v: Sym) -> Sym:
    return ca.vertcat(
        ca.horzcat(0, -v[2], v[1]),
        ca.horzcat(v[2], 0, -v[0]),
        ca.horzcat(-v[1], v[0], 0),
    )


def euler_zyx(alpha: Sym, beta: Sym, gamma: Sym) -> Sym:
    """R = Rz(alpha) Ry(beta) Rx(gamma): the hexapod platform orientation (thesis eq. 19)."""
    return rot_z(alpha) @ rot_y(beta) @ rot_x(gamma)


def rotvec_to_matrix(v: Sym) -> Sym:
    """Rodrigues' formula, exact (with exact derivatives) at v = 0."""
    theta_sq = ca.dot(v, v)
    small = theta_sq < _SMALL_ANGLE_SQ
    safe_sq = ca.if_else(small, 1.0, theta_sq)
    theta = ca.sqrt(safe_sq)
    sinc = ca.if_else(small, 1 - theta_sq / 6 + theta_sq**2 / 120, ca.sin(theta) / theta)
    cosc = ca.if_else(small, 0.5 - theta_sq / 24 + theta_sq**2 / 720, (1 - ca.cos(theta)) / safe_sq)
    k = skew(v)
    eye = ca.SX.eye(3) if isinstance(v, ca.SX) else ca.MX.eye(3)
    return eye + sinc * k + cosc * (k @ k)


def matrix_to_rotvec(r: Sym) -> Sym:
    """Logarithm of a rotation matrix as a rotation vector, for angles below pi.

    Used for orientation residuals, which are small after registration; the
    formula is exact (and smooth) at the identity.
    """
    w = 0.5 * ca.vertcat(r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1])
    sin_sq = ca.dot(w, w)
    cos_theta = 0.5 * (r[0, 0] + r[1, 1] + r[2, 2] - 1)
    small = sin_sq < _SMALL_ANGLE_SQ
    safe_sin = ca.sqrt(ca.if_else(small, 1.0, sin_sq))
    # theta / sin(theta) = 1 + sin²/6 + ... near zero (cos ≈ 1 there).
    factor = ca.if_else(small, 1 + sin_sq / 6, ca.atan2(safe_sin, cos_theta) / safe_sin)
    return factor * w


# ---------------------------------------------------------------- numeric side


def quaternion_to_matrix(q: ArrayLike) -> NDArray[np.float64]:
    """Rotation matrices from quaternions `[w, x, y, z]` (..., 4) -> (..., 3, 3); normalises."""
    quat = np.asarray(q, dtype=float)
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    w, x, y, z = np.moveaxis(quat, -1, 0)
    out = np.empty((*quat.shape[:-1], 3, 3))
    out[..., 0, 0] = 1 - 2 * (y * y + z * z)
    out[..., 0, 1] = 2 * (x * y - w * z)
    out[..., 0, 2] = 2 * (x * z + w * y)
    out[..., 1, 0] = 2 * (x * y + w * z)
    out[..., 1, 1] = 1 - 2 * (x * x + z * z)
    out[..., 1, 2] = 2 * (y * z - w * x)
    out[..., 2, 0] = 2 * (x * z - w * y)
    out[..., 2, 1] = 2 * (y * z + w * x)
    out[..., 2, 2] = 1 - 2 * (x * x + y * y)
    return out


def matrix_to_quaternion(r: ArrayLike) -> NDArray[np.float64]:
    """Quaternions `[w, x, y, z]` with w >= 0 from rotation matrices (..., 3, 3).

    Shepperd's method: picks the largest of (w, x, y, z) to divide by, so it is
    accurate for every rotation.
    """
    mat = np.asarray(r, dtype=float)
    flat = mat.reshape(-1, 3, 3)
    trace = np.trace(flat, axis1=1, axis2=2)
    diag = np.stack([trace, flat[:, 0, 0], flat[:, 1, 1], flat[:, 2, 2]], axis=1)
    pick = np.argmax(diag, axis=1)
    q = np.empty((flat.shape[0], 4))
    for k in range(flat.shape[0]):
        m = flat[k]
        match pick[k]:
            case 0:
                s = 2.0 * np.sqrt(max(1.0 + trace[k], 0.0))
                q[k] = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
            case 1:
                s = 2.0 * np.sqrt(max(1.0 + m[0, 0] - m[1, 1] - m[2, 2], 0.0))
                q[k] = [(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s]
            case 2:
                s = 2.0 * np.sqrt(max(1.0 + m[1, 1] - m[0, 0] - m[2, 2], 0.0))
                q[k] = [(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s, (m[1, 2] + m[2, 1]) / s]
            case _:
                s = 2.0 * np.sqrt(max(1.0 + m[2, 2] - m[0, 0] - m[1, 1], 0.0))
                q[k] = [(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s, (m[1, 2] + m[2, 1]) / s, 0.25 * s]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return q.reshape(*mat.shape[:-2], 4)


def rotvec_to_matrix_np(v: ArrayLike) -> NDArray[np.float64]:
    """Numeric Rodrigues for (..., 3) rotation vectors."""
    vec = np.asarray(v, dtype=float)
    theta = np.linalg.norm(vec, axis=-1)
    half = 0.5 * theta
    # sin(theta/2)/theta, finite at 0
    s = np.where(theta > 1e-12, np.sin(half) / np.where(theta > 1e-12, theta, 1.0), 0.5)
    quat = np.concatenate([np.cos(half)[..., None], s[..., None] * vec], axis=-1)
    return quaternion_to_matrix(quat)


def matrix_to_rotvec_np(r: ArrayLike) -> NDArray[np.float64]:
    """Numeric rotation vectors (..., 3) from rotation matrices, any angle up to pi."""
    q = matrix_to_quaternion(r)
    vec = q[..., 1:]
    sin_half = np.linalg.norm(vec, axis=-1)
    angle = 2.0 * np.arctan2(sin_half, q[..., 0])
    scale = np.where(sin_half > 1e-12, angle / np.where(sin_half > 1e-12, sin_half, 1.0), 2.0)
    return scale[..., None] * vec
