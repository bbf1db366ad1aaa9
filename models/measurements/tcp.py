"""The tracker's kinds: the TCP's pose, or its position alone, in the instrument's frame.

The instrument's frame is the robot's `base` (world <- robot base), so these kinds add no unknown of their
own. Their residual is the compiled `residual_at` (position error, then the rotation vector of R Rₘᵀ); the
position kind reads its first three rows and feeds identity rotations it never reads.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.description.parameters import ParameterSpec
from models.description.robot import RobotDescription
from models.measurement import MeasurementKind
from models.measurements.base import Index, ModelBatch
from models.noise import NoiseModel


@dataclass(frozen=True)
class TcpMeasurement:
    """The TCP measured in the instrument's frame: `rows` of (x, y, z, and the orientation's three)."""

    kind: MeasurementKind
    rows: int
    label: str
    columns: tuple[str, ...]

    POSE: ClassVar[TcpMeasurement]
    POSITION: ClassVar[TcpMeasurement]

    def unknowns(self, desc: RobotDescription) -> tuple[ParameterSpec, ...]:
        return ()

    def weights(self, noise: NoiseModel, sigma_mm: Array | None, n: int) -> Array:
        weights = np.tile([1 / noise.position_mm] * 3 + [1 / noise.orientation_rad] * 3, (n, 1))
        if sigma_mm is not None:
            weights[:, :3] = 1.0 / np.asarray(sigma_mm, dtype=float)[:, None]  # each record by its own σ
        return np.asarray(weights[:, : self.rows], dtype=float)

    def _rotations(self, campaign: Campaign, index: Index) -> Array:
        if campaign.quaternions is None:
            return np.broadcast_to(np.eye(3), (len(index), 3, 3)).copy()
        return np.asarray(campaign.rotations[index], dtype=float)

    def residuals(self, model: ModelBatch, campaign: Campaign, index: Index) -> Array:
        (res,) = self._evaluate("residual_at", model, campaign, index)
        return np.asarray(res[:, : self.rows], dtype=float)

    def residual_jacobians(self, model: ModelBatch, campaign: Campaign, index: Index) -> tuple[Array, Array]:
        res, jac = self._evaluate("residual_jacobian_at", model, campaign, index)
        return np.asarray(res[:, : self.rows]), np.asarray(jac[:, : self.rows, :])

    def _evaluate(self, name: str, model: ModelBatch, campaign: Campaign, index: Index) -> tuple[Array, ...]:
        """The compiled residual Function `name` at the records `index` (all six rows)."""
        rotations = self._rotations(campaign, index)
        m = model
        return m.functions.batch(
            name, m.q, m.theta, m.platforms, campaign.positions[index], rotations, conditions=m.conditions
        )

    def information(self, pose_jacobians: Array, noise: NoiseModel) -> Array:
        weights = self.weights(noise, None, 1)[0]
        return np.asarray(pose_jacobians[:, : self.rows, :] * weights[None, :, None], dtype=float)


TcpMeasurement.POSE = TcpMeasurement(MeasurementKind.POSE, 6, "full-pose", ("x", "y", "z", "qw", "qx", "qy", "qz"))
TcpMeasurement.POSITION = TcpMeasurement(MeasurementKind.POSITION, 3, "position-only", ("x", "y", "z"))
