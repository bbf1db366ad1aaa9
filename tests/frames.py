"""4x4 transforms written out for the tests, independently of `models`: the truth the exports' numbers are
multiplied out with (URDF's reading of an origin: Trans(xyz) · Rz(yaw) · Ry(pitch) · Rx(roll))."""

from __future__ import annotations

import math

import numpy as np


def rot(axis: int, a: float) -> np.ndarray:
    """A turn by `a` (rad) about x (0), y (1) or z (2)."""
    c, s = math.cos(a), math.sin(a)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    t = np.eye(4)
    t[i, i], t[i, j], t[j, i], t[j, j] = c, -s, s, c
    return t


def shift(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def xyz_rpy(x: float, y: float, z: float, roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Trans(x, y, z) · Rz(yaw) · Ry(pitch) · Rx(roll) (radians)."""
    t: np.ndarray = shift(x, y, z) @ rot(2, yaw) @ rot(1, pitch) @ rot(0, roll)
    return t
