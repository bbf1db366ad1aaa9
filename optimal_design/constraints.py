"""What users constrain: joint sub-ranges, a keep-out box in the world frame, a minimum spread between poses.

Filters remove candidates before anything else runs, so the relaxation, its
bound and the exchange all see only the admissible candidates: the bound is a
bound for the constrained problem. The minimum spread is a constraint between
chosen poses, not on single candidates: the relaxation ignores it (dropping a
constraint can only raise the relaxation, so the bound stays valid, if looser),
and rounding, greedy and exchange enforce it.

Spread metric: the distance between joint vectors q and q' is the root mean
square, over the joints, of their difference divided by that joint's range
width, `d(q, q') = sqrt(mean_k ((q_k − q'_k) / (hi_k − lo_k))²)`; it is 0 for
equal poses and 1 for poses at opposite corners of the joint box. Using the
range width makes millimetres of travel and radians of rotation comparable,
and the mean makes the number independent of the number of joints. Already
measured (fixed) poses count: a new pose must be as far from them too.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models import RobotDescription, forward_kinematics
from models._types import Array
from models.engine.runtime import Runtime
from models.errors import InvalidInput
from models.transforms import rotvec_to_matrix_np


@dataclass(frozen=True)
class KeepOut:
    """An axis-aligned box in the world frame (mm) that the TCP and the platform centre must stay outside."""

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    @classmethod
    def of(cls, box: KeepOut | Sequence[Sequence[float]]) -> KeepOut:
        if isinstance(box, KeepOut):
            return box
        lo, hi = np.asarray(box[0], dtype=float), np.asarray(box[1], dtype=float)
        if lo.shape != (3,) or hi.shape != (3,) or not np.all(np.isfinite(lo)) or not np.all(np.isfinite(hi)):
            raise InvalidInput("a keep-out box is two points (lower and upper corner) of three finite numbers each")
        if np.any(lo >= hi):
            raise InvalidInput(
                "the keep-out box's lower corner must be below its upper corner on every axis",
                field="keep_out",
                reason="inverted_box",
            )
        return cls((float(lo[0]), float(lo[1]), float(lo[2])), (float(hi[0]), float(hi[1]), float(hi[2])))

    def inside(self, points: Array) -> NDArray[np.bool_]:
        lo, hi = np.array(self.lower), np.array(self.upper)
        return np.asarray(np.all((points >= lo) & (points <= hi), axis=1))


def joint_range_mask(
    desc: RobotDescription, joints: Array, ranges: Mapping[int, tuple[float, float]]
) -> NDArray[np.bool_]:
    """Candidates whose joints lie in the given sub-ranges (joint index → (low, high), internal units)."""
    ok = np.ones(joints.shape[0], dtype=bool)
    for k, (lo, hi) in ranges.items():
        if not 0 <= int(k) < desc.n_joints:
            raise InvalidInput(
                f"joint index {k} is not one of the robot's {desc.n_joints} joints",
                field="joint_ranges",
                value=int(k),
                reason="unknown_joint",
            )
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
            raise InvalidInput(
                f"joint {k}: the sub-range must be finite with low <= high",
                field="joint_ranges",
                value=int(k),
                reason="invalid_range",
            )
        if hi < desc.joint_min[k] or lo > desc.joint_max[k]:
            raise InvalidInput(
                f"joint {k}: the sub-range [{lo}, {hi}] does not meet the joint's range "
                f"[{desc.joint_min[k]}, {desc.joint_max[k]}]",
                field="joint_ranges",
                value=int(k),
                reason="outside_joint_range",
            )
        ok &= (joints[:, k] >= lo) & (joints[:, k] <= hi)
    return ok


def platform_centres(
    desc: RobotDescription, joints: Array, params: Array | None = None, *, runtime: Runtime | None = None
) -> tuple[Array, Array]:
    """(TCP positions, platform centre positions) in the world frame, mm.

    world←platform = world←TCP · (platform←TCP)⁻¹ and platform←TCP is the tool transform (a translation and a
    rotation vector among the parameters), so the platform centre is p_tcp − R_tcp R_toolᵀ t_tool."""
    theta = desc.parameters.nominal if params is None else params
    fk = forward_kinematics(desc, joints, theta, runtime=runtime)
    tool = np.asarray(theta[desc.slices["tool"]], dtype=float)
    r_tool = rotvec_to_matrix_np(tool[3:6])
    offset = r_tool.T @ tool[:3]
    centres = fk.positions - np.einsum("nij,j->ni", fk.rotations, offset)
    return fk.positions, centres


def keep_out_mask(
    desc: RobotDescription, joints: Array, box: KeepOut, params: Array | None = None, *, runtime: Runtime | None = None
) -> NDArray[np.bool_]:
    """Candidates whose TCP and platform centre are both outside the box."""
    tcp, centre = platform_centres(desc, joints, params, runtime=runtime)
    return np.asarray(~(box.inside(tcp) | box.inside(centre)))


def scaled_joints(desc: RobotDescription, joints: Array) -> Array:
    """Joints divided by their range widths and by √n, so that Euclidean distance is the spread metric."""
    width = np.asarray(desc.joint_max, dtype=float) - np.asarray(desc.joint_min, dtype=float)
    return np.asarray(joints / (width * np.sqrt(desc.n_joints)))


def spread_distance(desc: RobotDescription, a: ArrayLike, b: ArrayLike) -> Array:
    """All pairwise spread distances (module docstring) between the rows of a and of b."""
    sa = scaled_joints(desc, np.atleast_2d(np.asarray(a, dtype=float)))
    sb = scaled_joints(desc, np.atleast_2d(np.asarray(b, dtype=float)))
    return _distances(sa, sb)


def _distances(sa: Array, sb: Array) -> Array:
    d2 = np.sum(sa**2, axis=1)[:, None] + np.sum(sb**2, axis=1)[None, :] - 2.0 * sa @ sb.T
    return np.asarray(np.sqrt(np.maximum(d2, 0.0)))


@dataclass(frozen=True)
class Spread:
    """The minimum spread between chosen poses (and between chosen and fixed ones), as masks."""

    scaled: Array
    """(M, n_joints) candidates, scaled (scaled_joints)."""
    fixed: Array
    """(F, n_joints) already measured poses, scaled."""
    minimum: float

    @classmethod
    def of(cls, desc: RobotDescription, candidates: Array, fixed: Array | None, minimum: float) -> Spread:
        if not np.isfinite(minimum) or not 0.0 <= minimum <= 1.0:
            raise InvalidInput(
                f"min_spread must be between 0 and 1, got {minimum}",
                field="min_spread",
                value=float(minimum),
                min=0,
                max=1,
            )
        done = fixed if fixed is not None else np.empty((0, desc.n_joints))
        return cls(scaled_joints(desc, candidates), scaled_joints(desc, done), float(minimum))

    def clear_of_fixed(self) -> NDArray[np.bool_]:
        if self.fixed.shape[0] == 0:
            return np.ones(self.scaled.shape[0], dtype=bool)
        return np.asarray(_distances(self.scaled, self.fixed).min(axis=1) >= self.minimum)

    def far_from(self, j: int) -> NDArray[np.bool_]:
        return np.asarray(_distances(self.scaled, self.scaled[j : j + 1])[:, 0] >= self.minimum)

    def clear(self, j: int, taken: Sequence[int]) -> bool:
        point = self.scaled[j : j + 1]
        if self.fixed.shape[0] and _distances(point, self.fixed).min() < self.minimum:
            return False
        return not taken or bool(_distances(point, self.scaled[list(taken)]).min() >= self.minimum)

    def swap_mask(self, design: NDArray[Any], pool: NDArray[Any]) -> NDArray[np.bool_]:
        """(len(design), len(pool)): may design[a] be replaced by pool[b] without breaking the spread?"""
        close = _distances(self.scaled[design], self.scaled[pool]) < self.minimum  # (I, J)
        n_close = close.sum(axis=0)
        ok_fixed = (
            _distances(self.scaled[pool], self.fixed).min(axis=1) >= self.minimum
            if self.fixed.shape[0]
            else np.ones(pool.size, dtype=bool)
        )
        # Allowed when no chosen pose is too close, or the only one that is, is the one leaving.
        return np.asarray(ok_fixed[None, :] & ((n_close[None, :] == 0) | ((n_close[None, :] == 1) & close)))

    def satisfied(self, design: NDArray[Any]) -> bool:
        d = _distances(self.scaled[design], self.scaled[design])
        np.fill_diagonal(d, np.inf)
        ok = d.size == 0 or bool(d.min() >= self.minimum)
        return ok and bool(self.clear_of_fixed()[design].all())

    def too_tight(self, count: int, got: int) -> InvalidInput:
        return InvalidInput(
            f"min_spread {self.minimum:g}: only {got} of the candidates fit at that spread, fewer than the "
            f"{count} asked for; lower min_spread or ask for fewer poses",
            field="min_spread",
            value=self.minimum,
            reason="too_tight",
        )
