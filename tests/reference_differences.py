"""Central differences of a reference's residuals (`models.measurements`: a reflector, a line, ...), the truth its
analytic derivatives are tested against: over the robot's parameters through the robot's own forward kinematics,
and over the reference's unknowns."""

from __future__ import annotations

from typing import Any

import numpy as np

from models import forward_kinematics
from models._types import Array
from models.description.robot import RobotDescription


def residual_differences(
    reference: Any, desc: RobotDescription, joints: Array, theta: Array, u: Array, values: Array, *, h_u: float
) -> tuple[Array, Array]:
    """(∂r/∂θ, ∂r/∂u) of `reference.residuals` at `joints`, by central differences: θ's steps 1e-5 of its internal
    units, u's `h_u`; each derivative on the last axis, as the residuals give theirs."""
    h = 1e-5

    def residuals(tcp: Any, unknowns: Array) -> Array:
        return np.asarray(reference.residuals(tcp, unknowns, values)[0])

    def moved(step: Array) -> Any:
        return forward_kinematics(desc, joints, theta + step, jacobian=True)

    by_theta = [(residuals(moved(h * e), u) - residuals(moved(-h * e), u)) / (2 * h) for e in np.eye(theta.size)]
    tcp = moved(np.zeros_like(theta))
    by_u = [(residuals(tcp, u + h_u * e) - residuals(tcp, u - h_u * e)) / (2 * h_u) for e in np.eye(u.size)]
    return np.stack(by_theta, axis=-1), np.stack(by_u, axis=-1)
