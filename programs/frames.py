"""The dialects' orientation conventions as 4x4 transforms (mm), and back, choosing among a rotation's
equivalent spellings the one nearest the source's (an angle a turn away, the other quaternion sign), so a small
correction changes the numbers by a small amount."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix, rotvec_to_matrix_np


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
    return np.asarray(rotvec_to_matrix_np(np.asarray(v, dtype=float)), dtype=float)


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
