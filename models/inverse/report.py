"""The answer of an inverse-kinematics call: checked by forward kinematics, with a reason per miss."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.inverse.nlp import bounds
from models.inverse.routing import REACHED_MM, joints_of
from models.kinematics import hexapod_condition, pose_batch, solve_platforms
from models.transforms import matrix_to_rotvec_np

REACHED_RAD = float(np.radians(1e-6))


@dataclass(frozen=True)
class IkSolution:
    """Joint commands for a batch of targets, with what they reach and how they were found."""

    joints: Array
    """(N, n_joints) commands, internal units; for an unreachable target those of the nearest reachable pose,
    NaN for an invalid target."""
    reachable: NDArray[np.bool_]
    position_error_mm: Array
    """Model TCP minus target for the returned joints (≈1e-9 mm when reachable; the miss otherwise)."""
    orientation_error_rad: Array | None
    reasons: tuple[str | None, ...]
    positions: Array
    """(N, 3) the TCP the returned joints give on the calibrated model."""
    rotations: Array
    condition: Array
    """Hexapod condition number at each answer (length-scaled eq. 48 Jacobian)."""
    methods: tuple[str, ...]
    """"newton" (KKT Newton, no bound active), "ipopt", "ipopt-nearest" (unreachable) or "invalid"."""
    seconds: float

    @property
    def size(self) -> int:
        return int(self.joints.shape[0])


def report(
    desc: RobotDescription,
    theta: Array,
    v: Array,
    p: Array,
    rot: Array | None,
    *,
    reasons: list[str | None],
    methods: list[str],
    started: float,
    runtime: Runtime,
) -> IkSolution:
    n = p.shape[0]
    joints = np.full((n, desc.n_joints), np.nan)
    positions = np.full((n, 3), np.nan)
    rotations = np.tile(np.eye(3), (n, 1, 1))
    condition = np.full(n, np.nan)
    solved = np.flatnonzero(np.isfinite(v).all(axis=1))
    if solved.size:
        # Into the ranges: the solvers honour the bounds to BOUND_SLACK (~1e-9), a controller may refuse 1e-9 over.
        joints[solved] = np.clip(joints_of(desc, theta, v[solved]), desc.joint_min, desc.joint_max)
        # The check goes the other way: legs -> platform by the hexapod's forward solution, then the TCP.
        platforms, _ = solve_platforms(desc, joints[solved], theta, v[solved, desc.n_chain :], runtime=runtime)
        fk = pose_batch(desc, joints[solved], theta, platforms, runtime=runtime)
        positions[solved], rotations[solved] = fk.positions, fk.rotations
        condition[solved] = hexapod_condition(desc, platforms, theta)
    pos_err = np.linalg.norm(positions - p, axis=1)
    rot_err = None
    if rot is not None:
        rot_err = np.linalg.norm(matrix_to_rotvec_np(rotations @ np.swapaxes(rot, 1, 2)), axis=1)
        rot_err[~np.isfinite(positions).all(axis=1)] = np.nan  # no answer, no error (not 0°)
    reachable = np.isfinite(pos_err) & (pos_err <= REACHED_MM)
    if rot_err is not None:
        reachable &= rot_err <= REACHED_RAD
    reachable &= np.array([r is None for r in reasons])
    final_reasons = list(reasons)
    for i in np.flatnonzero(~reachable):
        if final_reasons[i] is None:
            final_reasons[i] = why_unreachable(desc, theta, v[i], pos_err[i], None if rot_err is None else rot_err[i])
    return IkSolution(
        joints=joints,
        reachable=reachable,
        position_error_mm=pos_err,
        orientation_error_rad=rot_err,
        reasons=tuple(final_reasons),
        positions=positions,
        rotations=rotations,
        condition=condition,
        methods=tuple(methods),
        seconds=time.perf_counter() - started,
    )


def why_unreachable(desc: RobotDescription, theta: Array, v: Array, miss_mm: float, miss_rad: float | None) -> str:
    """Why a target is unreachable: the miss, and which joints, legs or workspace limits hold the answer."""
    lbx, ubx, lbl, ubl = bounds(desc)
    platforms = desc.n_unknowns // 6  # one platform pose per parallel stage
    names = [
        *desc.joint_names[: desc.n_chain],
        *(f"platform {axis}" for _ in range(platforms) for axis in ("x", "y", "z", "α", "β", "γ")),
    ]
    units = [*(k.boundary_unit for k in desc.joint_kinds[: desc.n_chain]), *(["mm"] * 3 + ["deg"] * 3) * platforms]
    scale = np.r_[desc.joint_to_boundary[: desc.n_chain], *([1.0] * 3 + [np.degrees(1.0)] * 3) * platforms]
    limits = []
    for k in range(v.size):
        for bound, word in ((lbx[k], "minimum"), (ubx[k], "maximum")):
            if abs(v[k] - bound) <= 1e-6 * max(1.0, abs(bound)):
                where = "the workspace limit" if k >= desc.n_chain else f"its {word}"
                limits.append(f"{names[k]} at {where} ({bound * scale[k]:.4g} {units[k]})")
    legs = joints_of(desc, theta, v[None, :])[0, desc.n_chain :]
    for k, leg in enumerate(legs):
        for bound, word in ((lbl[k], "shortest"), (ubl[k], "longest")):
            if abs(leg - bound) <= 1e-6 * bound:
                limits.append(f"leg {desc.joint_names[desc.n_chain + k]} at its {word} stroke ({bound:.4g} mm)")
    miss = f"the nearest reachable pose misses it by {miss_mm:.4g} mm"
    if miss_rad is not None:
        miss += f" and {np.degrees(miss_rad):.4g}°"
    cause = "; ".join(limits) if limits else "no joint at a limit (the solver did not converge)"
    return f"unreachable: {miss}; there {cause}"
