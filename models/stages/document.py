"""The primitives of reading a robots.md document: objects, numbers, intervals, poses.

Each raises `InvalidInput` naming the field by its path (`stages[1].links[2].range`), the message saying what
the value must be.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from models._types import Array, Pose6
from models.errors import InvalidInput
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix, rotvec_to_matrix_np

QUATERNION_NORM_TOLERANCE = 1e-3
DEG = math.pi / 180.0


def mapping(value: object, where: str, allowed: set[str]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise InvalidInput("must be an object", field=where)
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise InvalidInput(
            f"unknown key {unknown[0]!r}", field=f"{where}.{unknown[0]}", value=str(unknown[0]), allowed=sorted(allowed)
        )
    return value


def number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(float(value)):
        raise InvalidInput(f"must be a finite number, got {value!r}", field=where, value=str(value))
    return float(value)


def numbers(value: object, n: int, where: str) -> list[float]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise InvalidInput(f"must be a list of {n} numbers", field=where)
    return [number(v, f"{where}[{k}]") for k, v in enumerate(value)]


def interval(value: object, where: str) -> tuple[float, float]:
    lo, hi = numbers(value, 2, where)
    if not lo < hi:
        raise InvalidInput(f"range [{lo:g}, {hi:g}] needs lo < hi", field=where, min=lo, max=hi)
    return lo, hi


def quaternion(value: object, where: str) -> Array:
    q = np.array(numbers(value, 4, where))
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InvalidInput(f"must be a unit quaternion [w, x, y, z], norm {norm:.6g}", field=where, value=norm)
    return q / norm


def pose(value: object, where: str) -> Pose6:
    """A robots.md Pose as (x, y, z, rotation vector)."""
    raw = mapping(value, where, {"position", "orientation"})
    p = numbers(raw.get("position"), 3, f"{where}.position")
    rv = matrix_to_rotvec_np(quaternion_to_matrix(quaternion(raw.get("orientation"), f"{where}.orientation")))
    return (p[0], p[1], p[2], float(rv[0]), float(rv[1]), float(rv[2]))


def pose_document(pose6: Array) -> dict[str, list[float]]:
    """The robots.md Pose of (x, y, z, rotation vector)."""
    quat = matrix_to_quaternion(rotvec_to_matrix_np(pose6[3:6]))
    return {"position": [float(v) for v in pose6[:3]], "orientation": [float(v) for v in quat]}


def euler_zyx_of(r: Array) -> tuple[float, float, float]:
    """(α, β, γ) with R = Rz(α) Ry(β) Rx(γ), β in [-90°, 90°]."""
    beta = float(np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)))
    return float(np.arctan2(r[1, 0], r[0, 0])), beta, float(np.arctan2(r[2, 1], r[2, 2]))


def euler_zyx_matrix(alpha: float, beta: float, gamma: float) -> Array:
    ca_, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    rz = np.array([[ca_, -sa, 0], [sa, ca_, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cg, -sg], [0, sg, cg]])
    return np.asarray(rz @ ry @ rx, dtype=float)
