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
    return ok & np.all((legs >= lbl - BOUND_SLACK) & (legs <= ubl + BOUND_SLACK), axis=1)


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
    return v, met & within_bounds(desc, theta, v, runtime)
