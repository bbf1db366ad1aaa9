"""Closed-form registration of the instrument frame (Kabsch / Horn).

The instrument stands anywhere: metres away, at any rotation. Before any
iteration the nominal model's TCP positions are fitted rigidly onto the
measured ones, and the base transform (world <- {0}) is replaced by that fit
composed with the user's guess. The nonlinear solve then starts within the
geometric errors of the robot, never from the base guess.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.errors import InvalidInput
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

COLLINEAR_RTOL = 1e-6
"""Point sets whose second principal extent is below this fraction of the first cannot fix a rotation."""


@dataclass(frozen=True)
class RigidFit:
    rotation: Array
    translation: Array
    rms_mm: float
    """RMS distance between the fitted source points and the targets."""

    def apply(self, points: Array) -> Array:
        return points @ self.rotation.T + self.translation


def rigid_fit(source: Array, target: Array) -> RigidFit:
    """The rotation R and translation t minimising Σ‖R sᵢ + t − tᵢ‖² (SVD of the cross-covariance)."""
    if source.shape != target.shape or source.ndim != 2 or source.shape[1] != 3:
        raise InvalidInput(
            f"registration needs two point sets of equal shape (N, 3), got {source.shape} and {target.shape}"
        )
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    a, b = source - mu_s, target - mu_t
    spread = np.linalg.svd(b, compute_uv=False)
    if source.shape[0] < 3 or spread[1] <= COLLINEAR_RTOL * max(spread[0], 1e-300):
        raise InvalidInput(
            "the measured positions are (nearly) collinear, so the instrument frame cannot be registered: "
            "measure poses that spread in at least two directions",
            reason="collinear_positions",
        )
    u, _, vt = np.linalg.svd(a.T @ b)
    # Force a proper rotation: a reflection would fit mirrored data, never a real instrument.
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    rotation = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    translation = mu_t - rotation @ mu_s
    fitted = a @ rotation.T
    rms = float(np.sqrt(np.mean(np.sum((fitted - b) ** 2, axis=1))))
    return RigidFit(rotation, translation, rms)


def registered_base(desc: RobotDescription, params: Array, fit: RigidFit) -> Array:
    """Parameters whose base transform is `fit ∘ base`: the model then predicts in the instrument frame."""
    s_base = desc.slices["base"]
    base = params[s_base]
    rotation = fit.rotation @ rotvec_to_matrix_np(base[3:])
    translation = fit.rotation @ base[:3] + fit.translation
    out = params.copy()
    out[s_base] = np.r_[translation, matrix_to_rotvec_np(rotation)]
    return out
