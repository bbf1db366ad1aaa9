"""The inverse-kinematics problem of a robot structure, as CasADi expressions: one source for NLP and KKT.

Any number of joints for a six-dimensional (or position) target: the unknowns
`v` are the serial joints and, with a hexapod, its platform pose, the legs
following from the closed-form hexapod inverse kinematics (the IWR: 4 + 6).
Among the solutions, the one closest to a seed in joint space: `distance = Σ wⱼ (jointⱼ(v) − seedⱼ)²`.

One weights convention: `weights` are per joint and already divided by the
squared range of each joint (`joint_weights`), so that the graphs depend on
the structure alone and ranges, like geometry, stay inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from models._types import Array
from models.description.robot import RobotDescription, tcp_transform
from models.errors import InvalidInput, NonFiniteValue, WrongShape

ORIENTATION_LENGTH_MM = 1000.0
"""A radian of orientation error weighs like this many millimetres (about the robot's reach)."""
N_TARGET = 12
"""A target as NLP parameters: position (3) and the column-major rotation matrix (9)."""


def orientation_error(rotation: ca.SX, target: ca.SX) -> ca.SX:
    """sin(angle)·axis of R·Rtᵀ: smooth, and zero exactly when the orientations agree (angles below 90°)."""
    e = rotation @ target.T
    return 0.5 * ca.vertcat(e[2, 1] - e[1, 2], e[0, 2] - e[2, 0], e[1, 0] - e[0, 1])


@dataclass(frozen=True)
class IkProblem:
    """The symbols and expressions of the IK problem (see the module docstring)."""

    q: ca.SX
    """Carriage joints."""
    x: ca.SX
    """Platform pose."""
    theta: ca.SX
    target: ca.SX
    """Position and column-major rotation matrix (N_TARGET)."""
    seed: ca.SX
    weights: ca.SX
    """Per joint, already divided by the squared range of the joint."""
    legs: ca.SX
    joints: ca.SX
    distance: ca.SX
    position_error: ca.SX
    rotation_error: ca.SX
    """Scaled by ORIENTATION_LENGTH_MM, so comparable with millimetres."""

    @property
    def v(self) -> ca.SX:
        return ca.vertcat(self.q, self.x)

    def equations(self, *, position_only: bool) -> ca.SX:
        return self.position_error if position_only else ca.vertcat(self.position_error, self.rotation_error)


def ik_problem(desc: RobotDescription) -> IkProblem:
    q = ca.SX.sym("q_chain", desc.n_chain)
    # The closures' unknowns (platform poses; none without a parallel stage) and the legs they command.
    x = ca.SX.sym("platform", desc.n_unknowns)
    theta = ca.SX.sym("params", desc.n_params)
    target = ca.SX.sym("target", N_TARGET)
    seed = ca.SX.sym("seed", desc.n_joints)
    weights = ca.SX.sym("weights", desc.n_joints)
    legs = ca.vertcat(
        ca.SX(0, 1),
        *[
            stage.joint_expressions(x[at.unknowns], theta[at.params])
            for stage, at in desc.by_section
            if stage.n_unknowns
        ],
    )
    joints = ca.vertcat(q, legs)
    t = tcp_transform(desc, q, x, theta)
    return IkProblem(
        q=q,
        x=x,
        theta=theta,
        target=target,
        seed=seed,
        weights=weights,
        legs=legs,
        joints=joints,
        distance=ca.sum1(weights * (joints - seed) ** 2),
        position_error=t[0:3, 3] - target[0:3],
        rotation_error=orientation_error(t[0:3, 0:3], ca.reshape(target[3:12], 3, 3)) * ORIENTATION_LENGTH_MM,
    )


def joint_weights(desc: RobotDescription, weights: ArrayLike | None) -> Array:
    """The problem's weights from the user's per-joint multipliers of the range-normalised distance."""
    span = desc.joint_max - desc.joint_min
    if weights is None:
        return 1.0 / span**2
    w = np.asarray(weights, dtype=float).reshape(-1)
    if w.shape != (desc.n_joints,):
        raise WrongShape(
            f"weights must be {desc.n_joints} numbers, one per joint, got {w.size}",
            field="weights",
            expected=[desc.n_joints],
            got=list(w.shape),
        )
    if not np.isfinite(w).all():
        raise NonFiniteValue("weights must be finite")
    if (w < 0).any() or not (w > 0).any():
        raise InvalidInput("weights must be non-negative with at least one positive", field="weights")
    return w / span**2
