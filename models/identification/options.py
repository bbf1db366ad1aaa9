"""What the user may choose about an identification."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType

from models.errors import InvalidInput
from models.identification.prior import ParameterPrior

DEFAULT_GROUPS = ("base", "carriage", "hexapod", "tool")


class RobustLoss(StrEnum):
    """How gross errors are handled. AUTO (the default): plain least squares; only when the χ² test flags a
    pose, a soft-ℓ1 refit finds the blunders (least squares smears one blunder over many poses), they are
    excluded and plain least squares finishes on the rest. NONE: plain least squares, outliers only flagged."""

    AUTO = "auto"
    NONE = "none"
    HUBER = "huber"
    SOFT_L1 = "soft_l1"


@dataclass(frozen=True)
class IdentificationOptions:
    estimate: tuple[str, ...] = DEFAULT_GROUPS
    """Parameter groups and/or single parameter names to estimate; the rest stay at their nominal values."""
    robust: RobustLoss = RobustLoss.AUTO
    robust_scale: float = 3.0
    """Where the robust loss leaves the quadratic, in units of the instrument's σ."""
    exclude_outliers: bool = True
    """With a robust loss (or AUTO when it finds any): drop the flagged poses, finish with plain least squares."""
    outlier_alpha: float = 1e-3
    """Family-wise false-alarm probability of the outlier test over the whole campaign."""
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=lambda: MappingProxyType({}))
    """Optional bounds on parameter values, internal units (mm, rad), by parameter name."""
    max_iterations: int = 100
    workspace_samples: int = 200
    """Poses over which the predicted TCP accuracy is averaged."""
    prior: ParameterPrior | None = None
    """MAP: what is known of the parameters beforehand (a fleet's population, `models.evaluation.fleet`); None: the data
    alone (see `models.identification.prior`)."""

    def __post_init__(self) -> None:
        if not self.robust_scale > 0:
            raise InvalidInput("robust_scale must be positive")
        if not 0 < self.outlier_alpha < 1:
            raise InvalidInput("outlier_alpha must lie in (0, 1)")
        if self.max_iterations < 1:
            raise InvalidInput("max_iterations must be at least 1")
