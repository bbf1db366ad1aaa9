"""The inverse-kinematics NLPs of a robot structure, built once per structure by its runtime.

The problem of `problem.py` (10 variables, 6 target equations, 6 leg-stroke
inequalities); among the solutions IPOPT picks the one closest (weighted,
range-normalised) to a seed in joint space. Everything that varies between
requests (target, seed, weights, the calibrated parameters, the bounds) is an
NLP parameter or a bound, so the solvers below are built once and a batch is
one call of a mapped solver: no graph is built per request and no Python runs
per target.

`exact`: the TCP equals the target (position, and orientation unless
position-only). `nearest`: when `exact` is infeasible, the reachable pose
closest to the target (position mm plus orientation scaled by
`ORIENTATION_LENGTH_MM`), within every range.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.inverse.problem import ik_problem
from models.kinematics import platform_envelope

IPOPT = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    "ipopt.tol": 1e-12,
    "ipopt.constr_viol_tol": 1e-11,
    "ipopt.max_iter": 200,
    "ipopt.mu_strategy": "adaptive",
    "show_eval_warnings": False,
}


@dataclass(frozen=True)
class IkSolvers:
    exact_pose: ca.Function
    exact_position: ca.Function
    nearest_pose: ca.Function
    nearest_position: ca.Function

    def solver(self, *, exact: bool, position_only: bool) -> ca.Function:
        if exact:
            return self.exact_position if position_only else self.exact_pose
        return self.nearest_position if position_only else self.nearest_pose


def _build(desc: RobotDescription) -> IkSolvers:
    ik = ik_problem(desc)
    p = ca.vertcat(ik.target, ik.seed, ik.weights, ik.theta)
    out: dict[str, ca.Function] = {}
    for position_only in (False, True):
        equations = ik.equations(position_only=position_only)
        label = "position" if position_only else "pose"
        exact = {"x": ik.v, "p": p, "f": ik.distance, "g": ca.vertcat(equations, ik.legs)}
        out[f"exact_{label}"] = ca.nlpsol(f"ik_exact_{label}", "ipopt", exact, IPOPT)
        # Far from the target the distance term only breaks ties: a millimetre of miss costs 1e6 of it.
        miss = ca.sumsqr(equations) + 1e-6 * ik.distance
        nearest = {"x": ik.v, "p": p, "f": miss, "g": ik.legs}
        out[f"nearest_{label}"] = ca.nlpsol(f"ik_nearest_{label}", "ipopt", nearest, IPOPT)
    return IkSolvers(out["exact_pose"], out["exact_position"], out["nearest_pose"], out["nearest_position"])


def ik_solvers(desc: RobotDescription, runtime: Runtime | None = None) -> IkSolvers:
    """The solvers of this robot structure; geometry, base, tool, ranges and weights are parameters."""
    rt = runtime_for(desc, runtime)
    return rt.artefact("ik_nlp", None, lambda: _build(desc))


def bounds(desc: RobotDescription) -> tuple[Array, Array, Array, Array]:
    """(lbx, ubx) on [q_chain, platform] and (lbg_legs, ubg_legs).

    The platform may go a little beyond the workspace box: half the margin that forward kinematics accepts,
    so that an answer on this bound still passes its checks on a slightly different real robot. The whole
    envelope stays far from singular (condition ≤ 5 there, against the limit of 100).
    """
    n = desc.n_chain
    if not desc.has_closure:
        return desc.joint_min.copy(), desc.joint_max.copy(), np.empty(0), np.empty(0)
    outer_low, outer_high = platform_envelope(desc)
    box_low, box_high = desc.platform_limits
    low, high = (box_low + outer_low) / 2, (box_high + outer_high) / 2
    lbx = np.r_[desc.joint_min[:n], low]
    ubx = np.r_[desc.joint_max[:n], high]
    return lbx, ubx, desc.joint_min[n:].copy(), desc.joint_max[n:].copy()
