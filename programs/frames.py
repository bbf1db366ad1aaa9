"""The dialects' orientation conventions as 4x4 transforms (mm), and back, choosing among a rotation's
equivalent spellings the one nearest the source's (an angle a turn away, the other quaternion sign), so a small
correction changes the numbers by a small amount."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix


def transform(position: ArrayLike, rotation: ArrayLike) -> Array:
    out = np.eye(4)
    out[:3, :3] = np.asarray(rotation, dtype=float)
    out[:3, 3] = np.asarray(position, dtype=float)
    return out


def _rz(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _ry(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def _rx(a: float) -> Array:
    c, s = np.cos(a), np.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def abc_matrix(a_deg: float, b_deg: float, c_deg: float) -> Array:
    """KUKA's A, B, C (degrees): R = Rz(A) Ry(B) Rx(C)."""
    a, b, c = np.radians([a_deg, b_deg, c_deg])
    return _rz(a) @ _ry(b) @ _rx(c)


def _near(angle: float, like: float) -> float:
    """`angle` plus the whole turns that bring it nearest `like` (degrees)."""
    return angle + 360.0 * round((like - angle) / 360.0)


def matrix_abc(r: Array, like: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> tuple[float, float, float]:
    """A, B, C (degrees) of a rotation, the solution of the two (B and 180° - B) nearest `like`."""
    b = float(np.degrees(np.arctan2(-r[2, 0], np.hypot(r[0, 0], r[1, 0]))))
    a = float(np.degrees(np.arctan2(r[1, 0], r[0, 0])))
    c = float(np.degrees(np.arctan2(r[2, 1], r[2, 2])))
    other = (a + 180.0, 180.0 - b, c + 180.0)
    best: tuple[float, float, float] | None = None
    for cand in ((a, b, c), other):
        near = (_near(cand[0], like[0]), _near(cand[1], like[1]), _near(cand[2], like[2]))
        if best is None or _distance(near, like) < _distance(best, like):
            best = near
    assert best is not None
    return best


def _distance(x: tuple[float, float, float], y: tuple[float, float, float]) -> float:
    return float(sum((p - q) ** 2 for p, q in zip(x, y, strict=True)))


def quaternion_matrix(q: ArrayLike) -> Array:
    """Rotation of a quaternion [w, x, y, z] (scalar first, as ABB's q1..q4); normalised."""
    return np.asarray(quaternion_to_matrix(np.asarray(q, dtype=float)), dtype=float)


def matrix_quaternion(r: Array, like: ArrayLike = (1.0, 0.0, 0.0, 0.0)) -> Array:
    """[w, x, y, z] of a rotation, with the sign of `like` (q and -q are the same rotation)."""
    q = np.asarray(matrix_to_quaternion(r), dtype=float)
    return -q if float(np.dot(q, np.asarray(like, dtype=float))) < 0 else q


def rotvec_matrix(v: ArrayLike) -> Array:
    """Rodrigues' formula for one rotation vector, in scalars: a program's 10 000 poses are read one by one,
    and numpy's per-call cost (`rotvec_to_matrix_np`, 60 µs) was a third of reading them."""
    x, y, z = (float(c) for c in np.asarray(v, dtype=float).reshape(3))
    angle = math.sqrt(x * x + y * y + z * z)
    if angle < 1e-12:
        return np.eye(3)
    kx, ky, kz = x / angle, y / angle, z / angle
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    return np.array(
        [
            [c + kx * kx * t, kx * ky * t - kz * s, kx * kz * t + ky * s],
            [ky * kx * t + kz * s, c + ky * ky * t, ky * kz * t - kx * s],
            [kz * kx * t - ky * s, kz * ky * t + kx * s, c + kz * kz * t],
        ]
    )


def matrix_rotvec(r: Array, like: ArrayLike = (0.0, 0.0, 0.0)) -> Array:
    """Rotation vector (radians) of a rotation, the spelling nearest `like`: near a half turn v and
    v - 2π v/|v| are the same rotation, and a controller's teach pendant writes either."""
    v = np.asarray(matrix_to_rotvec_np(r), dtype=float)
    ref = np.asarray(like, dtype=float)
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return v
    axis = v / angle
    candidates = [v, axis * (angle - 2 * np.pi), axis * (angle + 2 * np.pi)]
    return min(candidates, key=lambda c: float(np.linalg.norm(c - ref)))


# ---------------------------------------------------------------- whole batches (a program's targets at once)


def quaternions(r: Array) -> Array:
    """(N, 4) [w, x, y, z] of (N, 3, 3) rotations, w >= 0: Shepperd's choice of the largest component to divide
    by, for every rotation at once (`models.transforms.matrix_to_quaternion` loops over them)."""
    m = np.asarray(r, dtype=float).reshape(-1, 3, 3)
    t = np.trace(m, axis1=1, axis2=2)
    d = np.stack([t, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    pick = np.argmax(d, axis=1)
    s = 2.0 * np.sqrt(np.maximum(1.0 + 2.0 * d[np.arange(len(m)), pick] - t, 1e-300))
    a21, a12 = m[:, 2, 1], m[:, 1, 2]
    a02, a20 = m[:, 0, 2], m[:, 2, 0]
    a10, a01 = m[:, 1, 0], m[:, 0, 1]
    cases = np.stack(
        [
            np.stack([0.25 * s, (a21 - a12) / s, (a02 - a20) / s, (a10 - a01) / s], axis=1),
            np.stack([(a21 - a12) / s, 0.25 * s, (a01 + a10) / s, (a02 + a20) / s], axis=1),
            np.stack([(a02 - a20) / s, (a01 + a10) / s, 0.25 * s, (a12 + a21) / s], axis=1),
            np.stack([(a10 - a01) / s, (a02 + a20) / s, (a12 + a21) / s, 0.25 * s], axis=1),
        ],
        axis=1,
    )
    q = cases[np.arange(len(m)), pick]
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    out: Array = q / np.linalg.norm(q, axis=1, keepdims=True)
    return out


def quaternions_like(r: Array, like: Array) -> Array:
    """Quaternions with the signs of `like` (N, 4)."""
    q = quaternions(r)
    return np.where(np.sum(q * like, axis=1, keepdims=True) < 0, -q, q)


def rotvecs_like(r: Array, like: Array) -> Array:
    """(N, 3) rotation vectors (radians), each the spelling nearest its `like` (v, or v a turn shorter/longer)."""
    q = quaternions(r)
    sin_half = np.linalg.norm(q[:, 1:], axis=1)
    angle = 2.0 * np.arctan2(sin_half, q[:, 0])
    axis = np.where(sin_half[:, None] > 1e-12, q[:, 1:] / np.where(sin_half > 1e-12, sin_half, 1.0)[:, None], 0.0)
    candidates = np.stack([axis * (angle + k * 2 * np.pi)[:, None] for k in (0, -1, 1)], axis=1)
    best = np.argmin(np.linalg.norm(candidates - like[:, None, :], axis=2), axis=1)
    out: Array = candidates[np.arange(len(q)), best]
    return out


def abcs_like(r: Array, like: Array) -> Array:
    """(N, 3) KUKA A, B, C (degrees), of the two solutions the one nearest `like`, each angle a whole number of
    turns from where it is computed to lie nearest its `like`."""
    b = np.degrees(np.arctan2(-r[:, 2, 0], np.hypot(r[:, 0, 0], r[:, 1, 0])))
    a = np.degrees(np.arctan2(r[:, 1, 0], r[:, 0, 0]))
    c = np.degrees(np.arctan2(r[:, 2, 1], r[:, 2, 2]))
    first = np.stack([a, b, c], axis=1)
    second = np.stack([a + 180.0, 180.0 - b, c + 180.0], axis=1)
    near = [x + 360.0 * np.round((like - x) / 360.0) for x in (first, second)]
    pick = np.sum((near[1] - like) ** 2, axis=1) < np.sum((near[0] - like) ** 2, axis=1)
    out: Array = np.where(pick[:, None], near[1], near[0])
    return out
