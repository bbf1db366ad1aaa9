"""The inverse-kinematics NLPs of a hybrid robot, built once per robot structure.

Ten joints for a six-dimensional target: the unknowns are the carriage joints
and the hexapod's platform pose; the legs follow from the closed-form hexapod
inverse kinematics, so the NLP has 10 variables, 6 target equations and 6
leg-stroke inequalities. Among the solutions IPOPT picks the one closest
(weighted, range-normalised) to a seed in joint space. Everything that varies
between requests (target, seed, weights, the calibrated parameters) is an NLP
parameter, so the solvers below are built once and a batch is one call of a
mapped solver: no graph is built per request and no Python runs per target.

`exact`: the TCP equals the target (position, and orientation unless
position-only). `nearest`: when `exact` is infeasible, the reachable pose
closest to the target (position mm plus orientation scaled by
`ORIENTATION_LENGTH_MM`), within every range.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from models import hexapod as hx
from models.hybrid import RobotDescription, tcp_transform
from models.kinematics import Array, platform_envelope

ORIENTATION_LENGTH_MM = 1000.0
"""A radian of orientation error weighs like this many millimetres (about the robot's reach)."""

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
N_TARGET = 12
"""A target as NLP parameters: position (3) and the column-major rotation matrix (9)."""


def orientation_error(rotation: ca.SX, target: ca.SX) -> ca.SX:
    """sin(angle)·axis of R·Rtᵀ: smooth, and zero exactly when the orientations agree (angles below 90°)."""
    e = rotation @ target.T
    return 0.5 * ca.vertcat(e[2, 1] - e[1, 2], e[0, 2] - e[2, 0], e[1, 0] - e[0, 1])


@dataclass(frozen=True)
class IkSolvers:
    exact_pose: ca.Function
    exact_position: ca.Function
    nearest_pose: ca.Function
    nearest_position: ca.Function
    legs: ca.Function
    """(q_chain, platform, params) -> commanded legs."""

    def solver(self, *, exact: bool, position_only: bool) -> ca.Function:
        if exact:
            return self.exact_position if position_only else self.exact_pose
        return self.nearest_position if position_only else self.nearest_pose


def _build(desc: RobotDescription) -> IkSolvers:
    n_chain = desc.n_chain
    s_hex = desc.slices["hexapod"]
    q = ca.SX.sym("q_chain", n_chain)
    x = ca.SX.sym("platform", 6)
    theta = ca.SX.sym("params", desc.n_params)
    target = ca.SX.sym("target", N_TARGET)
    seed = ca.SX.sym("seed", desc.n_joints)
    weights = ca.SX.sym("weights", desc.n_joints)
    legs = hx.actuator_lengths(x, theta[s_hex])
    joints = ca.vertcat(q, legs)
    span = np.asarray(desc.joint_max - desc.joint_min, dtype=float)
    distance = ca.sum1(weights * ((joints - seed) / span) ** 2)
    t = tcp_transform(desc, q, x, theta)
    p_target, r_target = target[0:3], ca.reshape(target[3:12], 3, 3)
    position_error = t[0:3, 3] - p_target
    rotation_error = orientation_error(t[0:3, 0:3], r_target) * ORIENTATION_LENGTH_MM
    decision = ca.vertcat(q, x)
    p = ca.vertcat(target, seed, weights, theta)
    out: dict[str, ca.Function] = {}
    for position_only in (False, True):
        equations = position_error if position_only else ca.vertcat(position_error, rotation_error)
        label = "position" if position_only else "pose"
        exact = {"x": decision, "p": p, "f": distance, "g": ca.vertcat(equations, legs)}
        out[f"exact_{label}"] = ca.nlpsol(f"ik_exact_{label}", "ipopt", exact, IPOPT)
        # Far from the target the distance term only breaks ties: a millimetre of miss costs 1e6 of it.
        miss = ca.sumsqr(equations) + 1e-6 * distance
        nearest = {"x": decision, "p": p, "f": miss, "g": legs}
        out[f"nearest_{label}"] = ca.nlpsol(f"ik_nearest_{label}", "ipopt", nearest, IPOPT)
    legs_fn = ca.Function("legs", [q, x, theta], [legs])
    return IkSolvers(out["exact_pose"], out["exact_position"], out["nearest_pose"], out["nearest_position"], legs_fn)


_LOCK = threading.Lock()
_BUILT: dict[tuple[Any, ...], IkSolvers] = {}


def ik_solvers(desc: RobotDescription) -> IkSolvers:
    """The solvers of this robot structure and joint ranges; geometry, base and tool are NLP parameters."""
    key = (
        tuple(link.joint for link in desc.links),
        tuple(desc.joint_min.tolist()),
        tuple(desc.joint_max.tolist()),
    )
    with _LOCK:
        found = _BUILT.get(key)
        if found is None:
            found = _BUILT[key] = _build(desc)
        return found


def bounds(desc: RobotDescription) -> tuple[Array, Array, Array, Array]:
    """(lbx, ubx) on [q_chain, platform] and (lbg_legs, ubg_legs).

    The platform may go a little beyond the workspace box: half the margin that forward kinematics accepts,
    so that an answer on this bound still passes its checks on a slightly different real robot. The whole
    envelope stays far from singular (condition ≤ 5 there, against the limit of 100).
    """
    n = desc.n_chain
    outer_low, outer_high = platform_envelope(desc)
    box_low, box_high = np.asarray(desc.hexapod.workspace_min), np.asarray(desc.hexapod.workspace_max)
    low, high = (box_low + outer_low) / 2, (box_high + outer_high) / 2
    lbx = np.r_[desc.joint_min[:n], low]
    ubx = np.r_[desc.joint_max[:n], high]
    lbl = np.full(6, desc.hexapod.stroke_min)
    ubl = np.full(6, desc.hexapod.stroke_max)
    return lbx, ubx, lbl, ubl
