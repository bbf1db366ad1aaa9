"""The weighted least-squares problem of one campaign, evaluated in native batches.

Unknowns are `z`, the free parameters in units of their scale:
`θ[free] = θ_start[free] + scale[free] · z`. Residuals are divided by the
instrument's σ, so a residual of 1 is one standard deviation and every column
of the Jacobian is "σ per tolerance". The hexapod's forward kinematics is
solved inside each evaluation (Newton, warm-started from the last platform
poses) and differentiated by the implicit function theorem in the compiled
`residual_jacobian_at`; nothing here depends on N except array sizes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.campaign import Campaign
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.identification.options import RobustLoss
from models.identification.prior import ParameterPrior, PriorRows
from models.kinematics import CLOSURE_TOLERANCE_MM, solve_platforms
from models.measurements import ModelBatch, measurement
from models.noise import NoiseModel


@dataclass(frozen=True)
class Loss:
    """ρ(s) of a squared standardised residual s, applied element-wise; `scale` in σ."""

    kind: RobustLoss = RobustLoss.NONE
    scale: float = 3.0

    def rho(self, s: Array) -> tuple[Array, Array]:
        """(ρ(s), ρ'(s)); ρ(s) = s for plain least squares."""
        c2 = self.scale**2
        if self.kind is RobustLoss.HUBER:
            root = np.sqrt(s)
            inside = s <= c2
            value = np.where(inside, s, 2.0 * self.scale * root - c2)
            slope = np.where(inside, 1.0, self.scale / np.maximum(root, 1e-300))
            return value, slope
        if self.kind is RobustLoss.SOFT_L1:
            root = np.sqrt(1.0 + s / c2)
            return 2.0 * c2 * (root - 1.0), 1.0 / root
        return s, np.ones_like(s)


@dataclass(frozen=True)
class Evaluation:
    theta: Array
    platforms: Array
    residuals: Array
    """(N, rows) standardised residuals (σ units)."""
    jacobian: Array
    """(N·rows, n_free) d residual / d z."""
    raw_jacobian: Array
    """(N, rows, n_params) unweighted d residual / d θ."""
    objective: float
    """½ Σ ρ(rᵢ²) / m: half the mean loss per equation (m equations)."""
    gradient: Array
    hessian: Array
    """Gauss–Newton (IRLS for robust losses): Σ ρ'ᵢ Jᵢᵀ Jᵢ, positive semi-definite."""


class FitProblem(Protocol):
    """What the solver and the polish ask of a least-squares problem: its unknowns and everything at a point."""

    @property
    def n_free(self) -> int: ...

    def evaluate(self, z: Array) -> Evaluation | None: ...


class EvaluatedOnce:
    """Everything at z, kept for the next call at the same z (IPOPT asks for f, ∇f and ∇²f at one point);
    None where the model is undefined (a hexapod that does not close, non-finite numbers). A problem provides
    `_evaluate` and a `_last` field."""

    _last: tuple[bytes, Evaluation | None] | None

    def evaluate(self, z: Array) -> Evaluation | None:
        key = np.asarray(z, dtype=float).tobytes()
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        result = self._evaluate(np.asarray(z, dtype=float))
        self._last = (key, result)
        return result

    def _evaluate(self, z: Array) -> Evaluation | None:
        raise NotImplementedError


@dataclass
class CampaignProblem(EvaluatedOnce):
    desc: RobotDescription
    runtime: Runtime
    """Of `desc`'s structure: its compiled Functions evaluate every batch."""
    campaign: Campaign
    noise: NoiseModel
    theta_start: Array
    free: Array
    """Indices of the estimated parameters."""
    loss: Loss = Loss()
    active: NDArray[np.intp] | None = None
    """Poses that count (outliers removed); None: all."""
    platforms: Array | None = None
    _last: tuple[bytes, Evaluation | None] | None = field(default=None, repr=False)
    evaluations: int = 0
    prior: ParameterPrior | None = None
    """MAP: a prior's rows join the objective, gradient and Hessian (`models.identification.prior`); `jacobian`
    and `residuals` of an evaluation stay the data's (outlier tests, variance factor)."""

    def __post_init__(self) -> None:
        self.runtime.check(self.desc)
        self.functions = self.runtime.kinematics
        self.measurement = measurement(self.campaign.kind)
        self.rows = self.measurement.rows
        self.weights = self.measurement.weights(self.noise, self.campaign.sigma_mm, self.campaign.size)
        """(N, rows) 1/σ per record and residual row."""
        self.scales = self.desc.parameters.scales[self.free]
        if self.active is None:
            self.active = np.arange(self.campaign.size, dtype=np.intp)
        self.conditions = self.campaign.condition_inputs(self.desc)
        """(N, 7) inputs of the model terms, None without terms."""
        self.prior_rows: PriorRows | None = (
            None if self.prior is None else self.prior.rows(self.theta_start, self.free, self.scales)
        )

    def _conditions(self) -> Array | None:
        return None if self.conditions is None else self.conditions[self.active_poses]

    @property
    def active_poses(self) -> NDArray[np.intp]:
        assert self.active is not None  # set in __post_init__
        return self.active

    @property
    def n_free(self) -> int:
        return int(self.free.size)

    def theta(self, z: Array) -> Array:
        theta = self.theta_start.copy()
        theta[self.free] += self.scales * z
        return theta

    def residual_vector(self, z: Array) -> Array:
        """Standardised residuals only (no Jacobian), flattened; NaN where the model is undefined."""
        assert self.active is not None
        theta = self.theta(np.asarray(z, dtype=float))
        q = self.campaign.joints[self.active]
        seeds = None if self.platforms is None else self.platforms[self.active]
        cond = self._conditions()
        platforms, closure = solve_platforms(self.desc, q, theta, seeds, runtime=self.runtime, conditions=cond)
        res = self.measurement.residuals(
            ModelBatch(self.functions, q, theta, platforms, cond), self.campaign, self.active
        )
        r = res * self.weights[self.active]
        r[~(closure <= CLOSURE_TOLERANCE_MM)] = np.nan
        return np.asarray(r.reshape(-1), dtype=float)

    def _evaluate(self, z: Array) -> Evaluation | None:
        self.evaluations += 1
        assert self.active is not None
        theta = self.theta(z)
        c = self.campaign
        q = c.joints[self.active]
        seeds = None if self.platforms is None else self.platforms[self.active]
        cond = self._conditions()
        platforms, closure = solve_platforms(self.desc, q, theta, seeds, runtime=self.runtime, conditions=cond)
        if not np.all(closure <= CLOSURE_TOLERANCE_MM):
            return None
        model = ModelBatch(self.functions, q, theta, platforms, cond)
        res, jac = self.measurement.residual_jacobians(model, c, self.active)
        w = self.weights[self.active]
        r = res * w
        j = jac[:, :, self.free] * w[:, :, None] * self.scales[None, None, :]
        j = j.reshape(-1, self.n_free)
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(j))):
            return None
        flat = r.reshape(-1)
        value, slope = self.loss.rho(flat**2)
        # Per equation, so that IPOPT's absolute stopping test means the same for 30 poses and for 1000.
        per = 1.0 / flat.size
        objective = 0.5 * per * float(value.sum())
        gradient = per * (j.T @ (slope * flat))
        hessian = per * ((j * slope[:, None]).T @ j)
        if self.prior_rows is not None:
            # Scaled per data equation like the rest, so the polish's decrement stays a χ² (σ²) figure.
            p = self.prior_rows.residuals(z)
            objective += 0.5 * per * float(p @ p)
            gradient = gradient + per * (self.prior_rows.jacobian.T @ p)
            hessian = hessian + per * self.prior_rows.information
        if self.platforms is None:
            self.platforms = np.tile(np.asarray(self.desc.platform_home, dtype=float), (c.size, 1))
        self.platforms[self.active] = platforms
        return Evaluation(theta, platforms, r, j, jac, objective, gradient, hessian)
