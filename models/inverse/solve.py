"""Inverse kinematics: joint commands that put a robot's TCP on target.

For each target (position and orientation, or position only) the joints
closest to a seed among all solutions within every range: carriage joints
within their ranges, legs within their strokes, the platform inside the
hexapod's workspace (where its condition number stays far from singular).

Route: a starting point from the nearest of a few thousand reachable poses of
the model (k-d tree, `starts.py`), then Newton on the KKT conditions for all
targets at once (`kkt.py`). Where that lands inside every bound it is the
solution of the IPOPT problem (`nlp.py`); the others are solved by IPOPT
itself, and targets IPOPT cannot reach exactly get the nearest reachable pose
and the reason. Every answer is checked by forward kinematics through the
hexapod's own forward solution.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array, finite_or_none
from models.campaign import QUATERNION_NORM_TOLERANCE
from models.errors import NonFiniteValue, WrongShape
from models.inverse.kkt import kkt_functions, newton_kkt
from models.inverse.nlp import bounds, ik_solvers
from models.inverse.problem import N_TARGET, joint_weights
from models.inverse.starts import start_table
from models.kinematics import (
    as_joint_array,
    check_joint_ranges,
    hexapod_condition,
    inverse_hexapod,
    pose_batch,
    solve_platforms,
)
from models.robot import RobotDescription
from models.runtime import Runtime, runtime_for
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix

REACHED_MM = 1e-6
REACHED_RAD = float(np.radians(1e-6))
BOUND_SLACK = 1e-9


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

    def to_dict(self, desc: RobotDescription) -> dict[str, Any]:
        """Boundary units: mm and degrees."""
        joints = self.joints * desc.joint_to_boundary
        quats = matrix_to_quaternion(self.rotations)
        orientation = None if self.orientation_error_rad is None else np.degrees(self.orientation_error_rad)
        num = finite_or_none

        return {
            "joints": [[num(v) for v in row] for row in joints],
            "position_error_mm": [num(v) for v in self.position_error_mm],
            "orientation_error_deg": None if orientation is None else [num(v) for v in orientation],
            "reachable": self.reachable.tolist(),
            "reasons": list(self.reasons),
            "reached_poses": [
                {"position": [num(v) for v in p], "orientation": [num(v) for v in q]}
                for p, q in zip(self.positions, quats, strict=True)
            ],
            "hexapod_condition": [num(v) for v in self.condition],
            "methods": list(self.methods),
            "seconds": self.seconds,
        }


def default_seed(desc: RobotDescription, runtime: Runtime | None = None) -> Array:
    """Mid-range carriage joints and the legs of the hexapod's home pose (nominal geometry)."""
    n = desc.n_chain
    legs = inverse_hexapod(desc, np.asarray(desc.hexapod.home, dtype=float)[None, :], runtime=runtime)[0]
    return np.r_[(desc.joint_min[:n] + desc.joint_max[:n]) / 2, legs]


def _targets(positions: ArrayLike, quaternions: ArrayLike | None) -> tuple[Array, Array | None, list[str | None]]:
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


def _seeds(desc: RobotDescription, seed: ArrayLike | None, n: int, runtime: Runtime) -> Array:
    if seed is None:
        return np.tile(default_seed(desc, runtime), (n, 1))
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


def inverse_kinematics(
    desc: RobotDescription,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    params: ArrayLike | None = None,
    *,
    seed: ArrayLike | None = None,
    weights: ArrayLike | None = None,
    follow: bool = False,
    runtime: Runtime | None = None,
) -> IkSolution:
    """Joint commands reaching each target on the robot with parameters `params` (internal units).

    `quaternions` None: position-only targets (orientation free). `seed`: one joint vector, or one per target
    (default: `default_seed`). `follow`: each target's seed is the previous target's answer, so a path stays
    smooth (the first uses `seed`). `weights`: per joint, multiplying the range-normalised distance to the seed.
    """
    started = time.perf_counter()
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    if not np.isfinite(theta).all():
        raise NonFiniteValue("the parameters contain non-finite numbers")
    p, rot, reasons = _targets(positions, quaternions)
    n = p.shape[0]
    seeds = _seeds(desc, seed, n, rt)
    w = joint_weights(desc, weights)
    position_only = rot is None
    valid = np.array([r is None for r in reasons])
    rot_all = rot if rot is not None else np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    target = np.hstack([p, rot_all.transpose(0, 2, 1).reshape(n, 9)])
    target[~valid] = 0.0

    v = np.full((n, desc.n_chain + 6), np.nan)
    methods = ["invalid"] * n
    if follow:
        previous: Array | None = None
        for i in np.flatnonzero(valid):
            s = seeds[i : i + 1] if previous is None else previous
            vi, mi = _solve(desc, theta, target[i : i + 1], s, w, position_only=position_only, runtime=rt)
            v[i], methods[i] = vi[0], mi[0]
            previous = _joints(desc, theta, vi, rt)
    else:
        idx = np.flatnonzero(valid)
        if idx.size:
            vi, mi = _solve(desc, theta, target[idx], seeds[idx], w, position_only=position_only, runtime=rt)
            v[idx] = vi
            for k, i in enumerate(idx):
                methods[i] = mi[k]
    return _report(desc, theta, v, p, rot, reasons=reasons, methods=methods, started=started, runtime=rt)


def _joints(desc: RobotDescription, theta: Array, v: Array, runtime: Runtime | None = None) -> Array:
    (legs,) = runtime_for(desc, runtime).kinematics.batch(
        "hexapod_ik", v[:, desc.n_chain :], theta[desc.slices["hexapod"]]
    )
    return np.hstack([v[:, : desc.n_chain], legs])


def _within_bounds(desc: RobotDescription, theta: Array, v: Array, runtime: Runtime | None = None) -> NDArray[np.bool_]:
    lbx, ubx, lbl, ubl = bounds(desc)
    legs = _joints(desc, theta, v, runtime)[:, desc.n_chain :]
    ok = np.all((v >= lbx - BOUND_SLACK) & (v <= ubx + BOUND_SLACK), axis=1)
    return ok & np.all((legs >= lbl - BOUND_SLACK) & (legs <= ubl + BOUND_SLACK), axis=1)


def _solve(
    desc: RobotDescription,
    theta: Array,
    target: Array,
    seeds: Array,
    w: Array,
    *,
    position_only: bool,
    runtime: Runtime,
) -> tuple[Array, list[str]]:
    """Route each target: KKT Newton from the nearest start; IPOPT where a bound is active or Newton did not
    converge; IPOPT's nearest reachable pose where the target cannot be reached exactly."""
    n = target.shape[0]
    start = start_table(desc, theta, runtime).nearest(target, position_only=position_only)
    lbx, ubx, _, _ = bounds(desc)
    v, converged = newton_kkt(
        kkt_functions(desc, runtime),
        start.copy(),
        target,
        seed=seeds,
        weights=np.broadcast_to(w, seeds.shape),
        theta=theta,
        lower=lbx,
        upper=ubx,
        position_only=position_only,
    )
    methods = ["newton"] * n
    good = converged & _within_bounds(desc, theta, v, runtime)
    rest = np.flatnonzero(~good)
    if rest.size:
        v[rest], exact = _ipopt(
            desc,
            theta,
            target[rest],
            seeds[rest],
            w,
            start=start[rest],
            position_only=position_only,
            exact=True,
            runtime=runtime,
        )
        for i in rest:
            methods[i] = "ipopt"
        missed = rest[~exact]
        if missed.size:
            v[missed], _ = _ipopt(
                desc,
                theta,
                target[missed],
                seeds[missed],
                w,
                start=start[missed],
                position_only=position_only,
                exact=False,
                runtime=runtime,
            )
            for i in missed:
                methods[i] = "ipopt-nearest"
    return v, methods


def _ipopt(
    desc: RobotDescription,
    theta: Array,
    target: Array,
    seeds: Array,
    w: Array,
    *,
    start: Array,
    position_only: bool,
    exact: bool,
    runtime: Runtime | None = None,
) -> tuple[Array, NDArray[np.bool_]]:
    """IPOPT on each target (one mapped call); returns the solutions and whether the equations hold."""
    n = target.shape[0]
    solver = ik_solvers(desc, runtime).solver(exact=exact, position_only=position_only)
    lbx, ubx, lbl, ubl = bounds(desc)
    m = 3 if position_only else 6
    lbg = np.r_[np.zeros(m), lbl] if exact else lbl
    ubg = np.r_[np.zeros(m), ubl] if exact else ubl
    params = np.hstack(
        [target[:, :N_TARGET], seeds, np.broadcast_to(w, seeds.shape), np.broadcast_to(theta, (n, theta.size))]
    )
    mapped = solver.map(n)
    out = mapped(
        x0=start.T,
        p=params.T,
        lbx=np.tile(lbx, (n, 1)).T,
        ubx=np.tile(ubx, (n, 1)).T,
        lbg=np.tile(lbg, (n, 1)).T,
        ubg=np.tile(ubg, (n, 1)).T,
    )
    v = np.asarray(out["x"], dtype=float).T.reshape(n, -1)
    g = np.asarray(out["g"], dtype=float).T.reshape(n, -1)
    met = np.abs(g[:, :m]).max(axis=1) <= REACHED_MM if exact else np.zeros(n, dtype=bool)
    return v, met & _within_bounds(desc, theta, v, runtime)


def _report(
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
        joints[solved] = _joints(desc, theta, v[solved], runtime)
        # The check goes the other way: legs -> platform by the hexapod's forward solution, then the TCP.
        platforms, _ = solve_platforms(desc, joints[solved], theta, v[solved, desc.n_chain :], runtime=runtime)
        fk = pose_batch(desc, joints[solved], theta, platforms, runtime=runtime)
        positions[solved], rotations[solved] = fk.positions, fk.rotations
        condition[solved] = hexapod_condition(desc, platforms, theta, runtime=runtime)
    pos_err = np.linalg.norm(positions - p, axis=1)
    rot_err = None
    if rot is not None:
        rot_err = np.linalg.norm(matrix_to_rotvec_np(rotations @ np.swapaxes(rot, 1, 2)), axis=1)
    reachable = np.isfinite(pos_err) & (pos_err <= REACHED_MM)
    if rot_err is not None:
        reachable &= rot_err <= REACHED_RAD
    reachable &= np.array([r is None for r in reasons])
    final_reasons = list(reasons)
    for i in np.flatnonzero(~reachable):
        if final_reasons[i] is None:
            final_reasons[i] = _why(
                desc, theta, v[i], pos_err[i], None if rot_err is None else rot_err[i], runtime=runtime
            )
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


def _why(
    desc: RobotDescription, theta: Array, v: Array, miss_mm: float, miss_rad: float | None, *, runtime: Runtime
) -> str:
    """Why a target is unreachable: the miss, and which joints, legs or workspace limits hold the answer."""
    lbx, ubx, lbl, ubl = bounds(desc)
    names = [
        *desc.joint_names[: desc.n_chain],
        "platform x",
        "platform y",
        "platform z",
        "platform α",
        "platform β",
        "platform γ",
    ]
    units = [*(k.boundary_unit for k in desc.joint_kinds[: desc.n_chain]), "mm", "mm", "mm", "deg", "deg", "deg"]
    scale = np.r_[desc.joint_to_boundary[: desc.n_chain], 1, 1, 1, *([np.degrees(1.0)] * 3)]
    limits = []
    for k in range(v.size):
        for bound, word in ((lbx[k], "minimum"), (ubx[k], "maximum")):
            if abs(v[k] - bound) <= 1e-6 * max(1.0, abs(bound)):
                where = "the workspace limit" if k >= desc.n_chain else f"its {word}"
                limits.append(f"{names[k]} at {where} ({bound * scale[k]:.4g} {units[k]})")
    legs = _joints(desc, theta, v[None, :], runtime)[0, desc.n_chain :]
    for k, leg in enumerate(legs):
        for bound, word in ((lbl[k], "shortest"), (ubl[k], "longest")):
            if abs(leg - bound) <= 1e-6 * bound:
                limits.append(f"leg l{k + 1} at its {word} stroke ({bound:.4g} mm)")
    miss = f"the nearest reachable pose misses it by {miss_mm:.4g} mm"
    if miss_rad is not None:
        miss += f" and {np.degrees(miss_rad):.4g}°"
    cause = "; ".join(limits) if limits else "no joint at a limit (the solver did not converge)"
    return f"unreachable: {miss}; there {cause}"
