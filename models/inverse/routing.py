"""Routing: KKT Newton for every target from its nearest start; IPOPT where a bound is active or Newton did
not converge; IPOPT's nearest reachable pose where the target cannot be reached exactly."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.inverse.kkt import kkt_functions, newton_kkt
from models.inverse.nlp import bounds, ik_solvers
from models.inverse.problem import N_TARGET
from models.inverse.starts import start_table
from models.robot import RobotDescription
from models.runtime import Runtime, runtime_for

SERIAL_STARTS = 8
"""Table starts tried by Newton per target on a serial arm, then the seed, before IPOPT. A 6R arm has up to 16
IK branches (elbow, shoulder, wrist) and the pose-nearest table entry often lies on another one, behind a
joint limit: on the UR5-like arm, from its nearest start alone 27 % of FK targets ended unreachable, with the
8 nearest and the seed 7 %, with IPOPT's further starts (below) none. The IWR (one branch through its
hexapod) keeps its single start."""
REACHED_MM = 1e-6
BOUND_SLACK = 1e-9


def joints_of(desc: RobotDescription, theta: Array, v: Array, runtime: Runtime | None = None) -> Array:
    if not desc.has_hexapod:
        return v.copy()
    (legs,) = runtime_for(desc, runtime).kinematics.batch(
        "hexapod_ik", v[:, desc.n_chain :], theta[desc.slices["hexapod"]]
    )
    return np.hstack([v[:, : desc.n_chain], legs])


def within_bounds(desc: RobotDescription, theta: Array, v: Array, runtime: Runtime | None = None) -> NDArray[np.bool_]:
    lbx, ubx, lbl, ubl = bounds(desc)
    legs = joints_of(desc, theta, v, runtime)[:, desc.n_chain :]
    ok = np.all((v >= lbx - BOUND_SLACK) & (v <= ubx + BOUND_SLACK), axis=1)
    within: NDArray[np.bool_] = ok & np.all((legs >= lbl - BOUND_SLACK) & (legs <= ubl + BOUND_SLACK), axis=1)
    return within


def route(
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
    good = converged & within_bounds(desc, theta, v, runtime)
    if not desc.has_hexapod:
        good &= _not_flipped(desc, theta, v, target, position_only=position_only, runtime=runtime)
    if not desc.has_hexapod and not good.all():
        table = start_table(desc, theta, runtime)
        for j in range(1, SERIAL_STARTS + 1):
            rest = np.flatnonzero(~good)
            if rest.size == 0:
                break
            # The seed itself last: a program's own joints (compensation) are usually on the right branch.
            other = (
                seeds[rest].copy()
                if j == SERIAL_STARTS
                else table.nearest_k(target[rest], j + 1, position_only=position_only)[:, j, :]
            )
            v_j, conv_j = newton_kkt(
                kkt_functions(desc, runtime),
                other.copy(),
                target[rest],
                seed=seeds[rest],
                weights=np.broadcast_to(w, seeds[rest].shape),
                theta=theta,
                lower=lbx,
                upper=ubx,
                position_only=position_only,
            )
            ok = conv_j & within_bounds(desc, theta, v_j, runtime)
            ok &= _not_flipped(desc, theta, v_j, target[rest], position_only=position_only, runtime=runtime)
            v[rest[ok]] = v_j[ok]
            good[rest[ok]] = True
            start[rest[ok]] = other[ok]
    rest = np.flatnonzero(~good)
    if rest.size:
        v[rest], exact = ipopt_solutions(
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
        if missed.size and not desc.has_hexapod:
            missed = _ipopt_other_starts(
                desc, theta, target, seeds=seeds, w=w, v=v, missed=missed, position_only=position_only, runtime=runtime
            )
        if missed.size:
            v[missed], _ = ipopt_solutions(
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


def _not_flipped(
    desc: RobotDescription, theta: Array, v: Array, target: Array, *, position_only: bool, runtime: Runtime
) -> NDArray[np.bool_]:
    """The orientation equations (sin(angle)·axis) also vanish half a turn away: a serial arm's wrist can
    converge there (seen on the track arm, 1 target in 40); such an answer is no answer."""
    if position_only:
        return np.ones(v.shape[0], dtype=bool)
    safe = np.where(np.isfinite(v), v, 0.0)
    _, rot = runtime_for(desc, runtime).kinematics.batch("pose_at", safe, theta, np.zeros((v.shape[0], 6)))
    wanted = target[:, 3:12].reshape(-1, 3, 3).transpose(0, 2, 1)
    return np.asarray(np.einsum("nij,nij->n", rot, wanted) > 1.0)  # trace(R Rtᵀ) > 1: angle below 90°


IPOPT_STARTS = 8
"""Table starts IPOPT tries on a serial arm where Newton failed everywhere. Measured, full-pose FK targets from
the default seed: track arm 84 % reached from one start, 100 % from four; UR5-like (DH) 94 % from four, 100 %
from eight; iiwa-like 98 % (one target in 50 stays missed)."""


def _ipopt_other_starts(
    desc: RobotDescription,
    theta: Array,
    target: Array,
    *,
    seeds: Array,
    w: Array,
    v: Array,
    missed: NDArray[np.intp],
    position_only: bool,
    runtime: Runtime,
) -> NDArray[np.intp]:
    """Exact IPOPT from the next nearest starts for the targets still missed; those still missed after."""
    table = start_table(desc, theta, runtime)
    for j in range(1, IPOPT_STARTS):
        if missed.size == 0:
            break
        other = table.nearest_k(target[missed], j + 1, position_only=position_only)[:, j, :]
        v_j, exact = ipopt_solutions(
            desc,
            theta,
            target[missed],
            seeds[missed],
            w,
            start=other,
            position_only=position_only,
            exact=True,
            runtime=runtime,
        )
        v[missed[exact]] = v_j[exact]
        missed = missed[~exact]
    return missed


def ipopt_solutions(
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
    if exact and not desc.has_hexapod:
        met &= _not_flipped(desc, theta, v, target, position_only=position_only, runtime=runtime_for(desc, runtime))
    return v, met & within_bounds(desc, theta, v, runtime)
