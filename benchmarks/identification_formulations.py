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
from dataclasses import dataclass
from typing import Any

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


@dataclass(frozen=True)
class _Build:
    """What both formulations are built from: the clock their build is timed from, the runtime's kinematic
    functions, the unknowns z (the free parameters in their tolerances, as the product's solver scales them) with
    θ(z) = θ_start + scales · z, and the campaign as the NLP's parameters: symbols q, pm, rm (joints, measured
    positions, measured rotations; one column a record) and the vector `p` they stand in."""

    started: float
    fns: Any
    n: int
    z: Any
    theta: Any
    q: Any
    pm: Any
    rm: Any
    campaign: Campaign

    @classmethod
    def start(cls, symbols: Any, desc: RobotDescription, campaign: Campaign, theta_start: Array, free: Array) -> _Build:
        """`symbols`: ca.MX or ca.SX, the graph the formulation is built in."""
        started = time.perf_counter()
        fns = default_registry().runtime(desc).kinematics
        z = symbols.sym("z", free.size)
        theta = symbols(theta_start)
        theta[free.tolist()] = theta[free.tolist()] + desc.parameters.scales[free] * z
        q, pm, rm = (symbols.sym(k, *a.shape) for k, a in zip(("q", "pm", "rm"), _data(campaign), strict=True))
        return cls(started, fns, campaign.size, z, theta, q, pm, rm, campaign)

    @property
    def p(self) -> Any:
        return ca.vertcat(ca.vec(self.q), ca.vec(self.pm), ca.vec(self.rm))

    def p_values(self) -> Array:
        """The campaign's values of `p`, in its order."""
        return np.concatenate([a.reshape(-1, order="F") for a in _data(self.campaign)])


def solve_nested(
    desc: RobotDescription, campaign: Campaign, theta_start: Array, free: Array, noise: NoiseModel
) -> dict[str, float]:
    build = _Build.start(ca.MX, desc, campaign, theta_start, free)
    qi, pi, ri, th = ca.MX.sym("q", desc.n_joints), ca.MX.sym("p", 3), ca.MX.sym("r", 9), ca.MX.sym("t", desc.n_params)
    assert desc.hexapod is not None
    pos, rot, _ = build.fns["fk"](qi, th, ca.DM(desc.hexapod.home))
    res = _residual(pos, rot, pi, ri, noise)
    per_pose = ca.Function("res", [qi, th, pi, ri], [ca.sumsqr(res)]).map(build.n)
    f = 0.5 * ca.sum2(per_pose(build.q, build.theta, build.pm, build.rm)) / (6 * build.n)
    solver = ca.nlpsol("nested", "ipopt", {"x": build.z, "f": f, "p": build.p}, OPTIONS)
    built = time.perf_counter()
    out = solver(x0=np.zeros(free.size), p=build.p_values())
    return _figures(build.started, built, solver, out)


def solve_implicit(
    desc: RobotDescription, campaign: Campaign, theta_start: Array, free: Array, noise: NoiseModel
) -> dict[str, float]:
    build = _Build.start(ca.SX, desc, campaign, theta_start, free)
    x = ca.SX.sym("x", 6, build.n)
    closure = build.fns["closure"].map(build.n)(build.q, build.theta, x)
    qi, th, xi = ca.SX.sym("q", desc.n_joints), ca.SX.sym("t", desc.n_params), ca.SX.sym("x", 6)
    pi, ri = ca.SX.sym("p", 3), ca.SX.sym("r", 9)
    pos, rot = build.fns["pose_at"](qi, th, xi)
    res = ca.Function("res", [qi, th, xi, pi, ri], [ca.sumsqr(_residual(pos, rot, pi, ri, noise))]).map(build.n)
    f = 0.5 * ca.sum2(res(build.q, build.theta, x, build.pm, build.rm)) / (6 * build.n)
    nlp = {"x": ca.vertcat(build.z, ca.vec(x)), "f": f, "g": ca.vec(closure), "p": build.p}
    solver = ca.nlpsol("implicit", "ipopt", nlp, OPTIONS)
    built = time.perf_counter()
    platforms, _ = solve_platforms(desc, campaign.joints, theta_start)
    x0 = np.concatenate([np.zeros(free.size), platforms.T.reshape(-1, order="F")])
    out = solver(x0=x0, p=build.p_values(), lbg=0, ubg=0)
    return _figures(build.started, built, solver, out)
