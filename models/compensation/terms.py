"""Compensation and inverse kinematics under the model terms: right at the temperature and load a program runs at.

Exact, without an inverse-kinematics problem of its own: at given conditions the terms' model *is* the geometric
model at other joint values. A prismatic axis that travels `q` moves `q (1 + κ_axes ΔT)`; a leg commanded to `l`
is `(l + δl)(1 + κ_legs ΔT) + c t` long, with `t` its tension at the platform pose (which the geometric solution
gives). So the geometric inverse kinematics finds the effective joints, and the commands follow in closed form:
`q = q_eff / (1 + κ_axes ΔT)`, `l = (l_eff + δl − c t) / (1 + κ_legs ΔT) − δl`. The answer is checked by the
terms' own forward kinematics.
"""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import JointType
from models.description.terms import Conditions, condition_inputs
from models.engine.runtime import Runtime, runtime_for
from models.inverse import IkSolution, inverse_kinematics
from models.kinematics import forward_kinematics, leg_tensions, solve_platforms
from models.transforms import matrix_to_rotvec_np, quaternion_to_matrix


def _factors(desc: RobotDescription, theta: Array, dt: Array) -> tuple[Array, Array]:
    """(N, n_chain) travel factors of the serial joints and (N,) of the legs at temperature differences dt."""
    chain = np.ones((dt.size, desc.n_chain))
    if "thermal.axes" in desc.term_index:
        prismatic = np.array([link.joint is JointType.PRISMATIC for link in desc.moving_links])
        chain[:, prismatic] = (1 + theta[desc.term_index["thermal.axes"]] * dt)[:, None]
    legs = np.ones(dt.size)
    if "thermal.legs" in desc.term_index:
        legs = 1 + theta[desc.term_index["thermal.legs"]] * dt
    return chain, legs


def effective_joints(desc: RobotDescription, theta: Array, joints: Array, cond: Array) -> Array:
    """The geometric model's joints that the terms' model at `cond` equals, leaving out the load (a seed)."""
    chain, legs = _factors(desc, theta, cond[:, 0])
    out = joints.copy()
    out[:, : desc.n_chain] *= chain
    if desc.hexapod is not None:
        off = theta[desc.slices["hexapod"]][6::7]
        out[:, desc.n_chain :] = (joints[:, desc.n_chain :] + off) * legs[:, None] - off
    return out


DEFLECTION_ITERATIONS = 8
"""Fixed-point steps q ← q_eff − k τ(q) of a serial robot's compliance: each multiplies the error by k ∂τ/∂q,
about 1e-3 for an arm's gearboxes, so a few reach round-off."""


def _undeflected(deflection: ca.Function, q_eff: Array, theta: Array, cond: Array, factor: Array) -> Array:
    """The serial joint commands q whose travel (`factor`, thermal) and compliance deflection put the joints at
    `q_eff`: q (1 + κ ΔT) + k τ(q) = q_eff, by fixed-point steps."""
    n, m = q_eff.shape[0], factor.shape[1]
    mapped = deflection.map(n)
    q = q_eff.copy()
    q[:, :m] = q_eff[:, :m] / factor
    for _ in range(DEFLECTION_ITERATIONS):
        d = np.asarray(mapped(q.T, np.tile(theta[:, None], (1, n)), cond.T)).T
        q[:, :m] = (q_eff[:, :m] - d) / factor
    return q[:, :m]


def terms_inverse_kinematics(
    desc: RobotDescription,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    params: ArrayLike | None = None,
    *,
    conditions: Conditions | None,
    seed: ArrayLike | None = None,
    weights: ArrayLike | None = None,
    follow: bool = False,
    runtime: Runtime | None = None,
    geometric_runtime: Runtime | None = None,
) -> IkSolution:
    """Joint commands reaching each target on the robot with model terms, under each target's `conditions`.

    `runtime` serves `desc`'s structure (its checking FK), `geometric_runtime` the geometric one (`desc.geometric`).
    `seed`, `weights` and `follow` act on the effective joints (they differ from the commands by micrometres).
    """
    # Long on purpose: the fixed-point loop between the geometric IK and the terms' correction carries its state
    # across rounds.
    geo = desc.geometric
    rt = runtime_for(desc, runtime)
    geo_rt = runtime_for(geo, geometric_runtime)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    theta_geo = theta[: geo.n_params]
    p = np.atleast_2d(np.asarray(positions, dtype=float))
    n = p.shape[0]
    cond = condition_inputs(desc.terms, conditions, n)
    seeds = None
    if seed is not None:
        s = np.atleast_2d(np.asarray(seed, dtype=float))
        s = np.broadcast_to(s, (n, desc.n_joints)) if s.shape[0] == 1 else s
        seeds = effective_joints(desc, theta, np.asarray(s, dtype=float), cond)
    sol = inverse_kinematics(geo, p, quaternions, theta_geo, seed=seeds, weights=weights, follow=follow, runtime=geo_rt)
    ok = np.flatnonzero(np.isfinite(sol.joints).all(axis=1))
    joints = sol.joints.copy()
    if ok.size == 0:
        return sol
    q_eff = sol.joints[ok]
    chain, legs = _factors(desc, theta, cond[ok, 0])
    if "joint_deflection" in rt.kinematics.functions:
        commands = _undeflected(rt.kinematics["joint_deflection"], q_eff, theta, cond[ok], chain)
        joints[ok, : desc.n_chain] = commands
    else:
        joints[ok, : desc.n_chain] = q_eff[:, : desc.n_chain] / chain
    if desc.hexapod is not None:
        off = theta_geo[desc.slices["hexapod"]][6::7]
        change = np.zeros((ok.size, 6))
        if desc.terms.compliance:
            platforms, _ = solve_platforms(geo, q_eff, theta_geo, runtime=geo_rt)
            tension = leg_tensions(
                geo, q_eff, theta_geo, platforms, force_world=cond[ok, 1:4], cog_mm=cond[ok, 4:7], runtime=geo_rt
            )
            c = theta[[desc.term_index[f"compliance.leg{k + 1}"] for k in range(6)]]
            change = tension * c[None, :]
        joints[ok, desc.n_chain :] = (q_eff[:, desc.n_chain :] + off - change) / legs[:, None] - off
    # The check: the terms' own forward kinematics at the commands and their conditions.
    sub = (conditions or Conditions()).subset(ok)
    fk = forward_kinematics(desc, joints[ok], theta, check_ranges=False, runtime=rt, conditions=sub)
    positions_out, rotations_out = sol.positions.copy(), sol.rotations.copy()
    positions_out[ok], rotations_out[ok] = fk.positions, fk.rotations
    pos_err = sol.position_error_mm.copy()
    pos_err[ok] = np.linalg.norm(fk.positions - p[ok], axis=1)
    rot_err = sol.orientation_error_rad
    if rot_err is not None and quaternions is not None:
        target = quaternion_to_matrix(np.atleast_2d(np.asarray(quaternions, dtype=float)))[ok]
        rot_err = rot_err.copy()
        rot_err[ok] = np.linalg.norm(matrix_to_rotvec_np(fk.rotations @ np.swapaxes(target, 1, 2)), axis=1)
    return replace(
        sol,
        joints=joints,
        positions=positions_out,
        rotations=rotations_out,
        position_error_mm=pos_err,
        orientation_error_rad=rot_err,
    )
