"""An independent, hand-written numpy IWR carriage (spec table), for closed-form checks."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

# (theta, d, a, alpha) of the spec's table, mm and rad; the joint adds to d (prismatic) or theta (revolute).
SPEC_DH = (
    (0.0, 0.0, 91.0, np.pi / 2),
    (np.pi / 2, 0.0, 0.0, np.pi / 2),
    (0.0, 331.0, 252.0, np.pi / 2),
    (0.0, 0.0, 354.0, -np.pi / 2),
)
PRISMATIC = (True, True, False, False)


def dh_matrix(theta: float, d: float, a: float, alpha: float) -> Array:
    ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
    return np.array(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0.0, sa, ca, d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def carriage_frame(q_chain: Array, dh_errors: Array | None = None) -> Array:
    """World <- {4} of the spec's carriage (identity base); `dh_errors` (16,) adds to (theta, d, a, alpha)."""
    errors = np.zeros(16) if dh_errors is None else dh_errors
    t = np.eye(4)
    for i, (theta, d, a, alpha) in enumerate(SPEC_DH):
        e = errors[4 * i : 4 * i + 4]
        joint_theta = theta + e[0] + (0.0 if PRISMATIC[i] else q_chain[i])
        joint_d = d + e[1] + (q_chain[i] if PRISMATIC[i] else 0.0)
        t = t @ dh_matrix(joint_theta, joint_d, a + e[2], alpha + e[3])
    return t
