"""The two textbook CasADi formulations of the identification NLP, for comparison only.

Both build one graph per campaign (its size grows with N), which is why the
product does not use them (see `models.identification.solver`):
- nested: the hexapod FK inside the objective through `casadi.rootfinder`,
  derivatives by CasADi's implicit-function-theorem AD, exact Hessian;
- implicit: the platform poses are decision variables and the leg-length
  closure equations are equality constraints.
"""

from __future__ import annotations

import time

import casadi as ca
import numpy as np

from models import NoiseModel, RobotDescription, default_registry
from models._types import Array
from models.campaign import Campaign
from models.kinematics import solve_platforms
from models.transforms import matrix_to_rotvec

OPTIONS = {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": False, "ipopt.tol": 1e-9}


def _data(campaign: Campaign) -> tuple[Array, Array, Array]:
    n = campaign.size
    rot = campaign.rotations if not campaign.position_only else np.broadcast_to(np.eye(3), (n, 3, 3))
    return campaign.joints.T, campaign.positions.T, rot.transpose(0, 2, 1).reshape(n, 9).T


def _residual(position: ca.MX, rotation: ca.MX, p_meas: ca.MX, r_meas_vec: ca.MX, noise: NoiseModel) -> ca.MX:
    r_meas = ca.reshape(r_meas_vec, 3, 3)
    pos = (position - p_meas) / noise.position_mm
    rot = matrix_to_rotvec(rotation @ r_meas.T) / noise.orientation_rad
    return ca.vertcat(pos, rot)


def _figures(started: float, built: float, solver: ca.Function, out: dict[str, ca.DM]) -> dict[str, float]:
    """What the formulations are compared by, called as the solve returns: the build's and the solve's seconds
    (from `started`, `built`), the objective reached and IPOPT's iterations."""
    done = time.perf_counter()
    return {
        "build_s": built - started,
        "solve_s": done - built,
        "total_s": done - started,
        "objective": float(out["f"]),
        "iterations": float(solver.stats()["iter_count"]),
    }


def solve_nested(
    desc: RobotDescription, campaign: Campaign, theta_start: Array, free: Array, noise: NoiseModel
) -> dict[str, float]:
    started = time.perf_counter()
    fns = default_registry().runtime(desc).kinematics
    n = campaign.size
    scales = desc.parameters.scales[free]
    q, pm, rm = (ca.MX.sym(k, *a.shape) for k, a in zip(("q", "pm", "rm"), _data(campaign), strict=True))
    z = ca.MX.sym("z", free.size)
    theta = ca.MX(theta_start)
    theta[free.tolist()] = theta[free.tolist()] + scales * z
    qi, pi, ri, th = ca.MX.sym("q", desc.n_joints), ca.MX.sym("p", 3), ca.MX.sym("r", 9), ca.MX.sym("t", desc.n_params)
    assert desc.hexapod is not None
    pos, rot, _ = fns["fk"](qi, th, ca.DM(desc.hexapod.home))
    res = _residual(pos, rot, pi, ri, noise)
    per_pose = ca.Function("res", [qi, th, pi, ri], [ca.sumsqr(res)]).map(n)
    f = 0.5 * ca.sum2(per_pose(q, theta, pm, rm)) / (6 * n)
    solver = ca.nlpsol("nested", "ipopt", {"x": z, "f": f, "p": ca.vertcat(ca.vec(q), ca.vec(pm), ca.vec(rm))}, OPTIONS)
    built = time.perf_counter()
    data = np.concatenate([a.reshape(-1, order="F") for a in _data(campaign)])
    out = solver(x0=np.zeros(free.size), p=data)
    return _figures(started, built, solver, out)


def solve_implicit(
    desc: RobotDescription, campaign: Campaign, theta_start: Array, free: Array, noise: NoiseModel
) -> dict[str, float]:
    started = time.perf_counter()
    fns = default_registry().runtime(desc).kinematics
    n = campaign.size
    scales = desc.parameters.scales[free]
    z = ca.SX.sym("z", free.size)
    x = ca.SX.sym("x", 6, n)
    theta = ca.SX(theta_start)
    for k, i in enumerate(free):
        theta[int(i)] = theta[int(i)] + scales[k] * z[k]
    q_np, pm_np, rm_np = _data(campaign)
    q, pm, rm = ca.SX.sym("q", *q_np.shape), ca.SX.sym("pm", 3, n), ca.SX.sym("rm", 9, n)
    closure = fns["closure"].map(n)(q, theta, x)
    qi, th, xi = ca.SX.sym("q", desc.n_joints), ca.SX.sym("t", desc.n_params), ca.SX.sym("x", 6)
    pi, ri = ca.SX.sym("p", 3), ca.SX.sym("r", 9)
    pos, rot = fns["pose_at"](qi, th, xi)
    res = ca.Function("res", [qi, th, xi, pi, ri], [ca.sumsqr(_residual(pos, rot, pi, ri, noise))]).map(n)
    f = 0.5 * ca.sum2(res(q, theta, x, pm, rm)) / (6 * n)
    nlp = {
        "x": ca.vertcat(z, ca.vec(x)),
        "f": f,
        "g": ca.vec(closure),
        "p": ca.vertcat(ca.vec(q), ca.vec(pm), ca.vec(rm)),
    }
    solver = ca.nlpsol("implicit", "ipopt", nlp, OPTIONS)
    built = time.perf_counter()
    platforms, _ = solve_platforms(desc, campaign.joints, theta_start)
    data = np.concatenate([a.reshape(-1, order="F") for a in (q_np, pm_np, rm_np)])
    x0 = np.concatenate([np.zeros(free.size), platforms.T.reshape(-1, order="F")])
    out = solver(x0=x0, p=data, lbg=0, ubg=0)
    return _figures(started, built, solver, out)
