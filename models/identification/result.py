"""The frozen outcome of an identification (internal units), and its boundary-unit (mm, deg) dictionary."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

import numpy as np

from models._types import Array, finite_or_none
from models.identifiability import Confounding
from models.identification.statistics import PoseErrors
from models.measurement import MeasurementKind
from models.parameters import ParameterTable

DEG = float(np.degrees(1.0))


def _rms(a: Array) -> float:
    return float(np.sqrt(np.mean(a**2)))


class Status(StrEnum):
    SUCCEEDED = "succeeded"
    FAILED = "failed"


@dataclass(frozen=True)
class ResidualSummary:
    """Per-pose error norms of a model against measurements: position mm, orientation angle rad."""

    rms_mm: float
    max_mm: float
    rms_rad: float | None
    """None for position-only data."""
    max_rad: float | None
    per_pose_mm: Array
    per_pose_rad: Array | None

    @staticmethod
    def of(errors: PoseErrors) -> ResidualSummary:
        pos, rot = errors.position_mm, errors.orientation_rad
        return ResidualSummary(
            rms_mm=_rms(pos),
            max_mm=float(pos.max()),
            rms_rad=None if rot is None else _rms(rot),
            max_rad=None if rot is None else float(rot.max()),
            per_pose_mm=pos,
            per_pose_rad=rot,
        )

    def to_dict(self, per_pose: bool = True) -> dict[str, Any]:
        out: dict[str, Any] = {"rms_mm": self.rms_mm, "max_mm": self.max_mm}
        # Degrees from the per-pose values, as the boundary always reported them (bit for bit).
        rot = None if self.per_pose_rad is None else self.per_pose_rad * DEG
        if rot is not None:
            out |= {"rms_deg": _rms(rot), "max_deg": float(rot.max())}
        if per_pose:
            out["per_pose_mm"] = self.per_pose_mm.tolist()
            if rot is not None:
                out["per_pose_deg"] = rot.tolist()
        return out


@dataclass(frozen=True)
class Outlier:
    pose: int
    position_mm: float
    orientation_rad: float | None
    """Angle of the orientation residual; None for position-only data."""
    statistic: float
    """Σ of the pose's squared standardised residuals (≈ χ² with 3 or 6 degrees of freedom when clean)."""
    threshold: float
    excluded: bool


@dataclass(frozen=True)
class SolverReport:
    """How the solver went, summed over its runs (the robust fit, then the refit without outliers)."""

    name: str
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    evaluations: int
    polish_steps: int = 0
    """Gauss–Newton steps taken after IPOPT (see `polish`)."""


@dataclass(frozen=True)
class PredictedAccuracy:
    """1-σ TCP uncertainty over sampled workspace poses, from the a-posteriori covariance."""

    rms_position_mm: float
    max_position_mm: float
    rms_orientation_rad: float
    max_orientation_rad: float
    poses: int

    @staticmethod
    def undefined() -> PredictedAccuracy:
        nan = float("nan")
        return PredictedAccuracy(nan, nan, nan, nan, 0)


@dataclass(frozen=True)
class IdentificationResult:
    status: Status
    """SUCCEEDED or FAILED (equal to the strings "succeeded", "failed"); a failed result must never be applied
    to a robot."""
    reason: str | None
    table: ParameterTable = field(repr=False)
    parameters: Array
    """All parameters, internal units: estimated ones at their estimate, the rest at their nominal value."""
    nominal: Array
    start: Array
    """Nominal values with the registered instrument frame as base: where the solve began."""
    estimated: tuple[int, ...]
    std_errors: Array
    """Internal units; NaN where a parameter was not estimated."""
    covariance: Array
    """A-posteriori covariance of the estimated parameters, internal units, in `estimated` order."""
    correlated_pairs: tuple[tuple[str, str, float], ...]
    confounding: tuple[Confounding, ...]
    rank: int
    condition_number: float
    """Of the scaled identification Jacobian on the estimated parameters."""
    identifiability_rechecked: bool
    """The data give the same rank at the solution as at the start (the linearisation held)."""
    residuals_before: ResidualSummary
    residuals_after: ResidualSummary
    variance_factor: float
    dof: int
    noise_consistent: bool
    outliers: tuple[Outlier, ...]
    solver: SolverReport
    predicted_accuracy: PredictedAccuracy
    kind: MeasurementKind
    measurements: int
    seconds: float
    notes: tuple[str, ...] = ()

    @property
    def succeeded(self) -> bool:
        return self.status is Status.SUCCEEDED

    @property
    def position_only(self) -> bool:
        return self.kind is MeasurementKind.POSITION

    @property
    def identifiable_names(self) -> tuple[str, ...]:
        return tuple(self.table.names[i] for i in self.estimated)

    @property
    def unidentifiable_names(self) -> tuple[str, ...]:
        chosen = set(self.estimated)
        return tuple(n for i, n in enumerate(self.table.names) if i not in chosen)

    def to_dict(self, per_pose: bool = True) -> dict[str, Any]:
        """Boundary units: mm and degrees."""
        t = self.table
        chosen = set(self.estimated)
        value, nominal, std = (t.as_boundary(v) for v in (self.parameters, self.nominal, self.std_errors))
        acc = self.predicted_accuracy
        return {
            "status": self.status.value,
            "reason": self.reason,
            "parameters": [
                {
                    "name": name,
                    "value": float(value[i]),
                    "unit": t.units[i],
                    "nominal": float(nominal[i]),
                    "std_error": finite_or_none(std[i]) if i in chosen else None,
                    "identifiable": i in chosen,
                }
                for i, name in enumerate(t.names)
            ],
            "identifiable": list(self.identifiable_names),
            "unidentifiable": list(self.unidentifiable_names),
            "confounding": {c.name: [{"with": p, "coefficient": k} for p, k in c.partners] for c in self.confounding},
            "correlated_pairs": [{"a": a, "b": b, "correlation": r} for a, b, r in self.correlated_pairs],
            "rank": self.rank,
            "condition_number": finite_or_none(self.condition_number),
            "identifiability_rechecked": self.identifiability_rechecked,
            "residuals": {
                "before": self.residuals_before.to_dict(per_pose),
                "after": self.residuals_after.to_dict(per_pose),
            },
            "variance_factor": finite_or_none(self.variance_factor),
            "degrees_of_freedom": self.dof,
            "noise_consistent": self.noise_consistent,
            "outliers": [
                {
                    "pose": o.pose,
                    "position_mm": o.position_mm,
                    "orientation_deg": None if o.orientation_rad is None else float(np.degrees(o.orientation_rad)),
                    "statistic": o.statistic,
                    "threshold": o.threshold,
                    "excluded": o.excluded,
                }
                for o in self.outliers
            ],
            "solver": {
                "name": self.solver.name,
                "status": self.solver.status,
                "success": self.solver.success,
                "iterations": self.solver.iterations,
                "seconds": self.solver.seconds,
                "evaluations": self.solver.evaluations,
                "polish_steps": self.solver.polish_steps,
            },
            "predicted_accuracy": {
                "rms_position_mm": finite_or_none(acc.rms_position_mm),
                "max_position_mm": finite_or_none(acc.max_position_mm),
                "rms_orientation_deg": finite_or_none(float(np.degrees(acc.rms_orientation_rad))),
                "max_orientation_deg": finite_or_none(float(np.degrees(acc.max_orientation_rad))),
                "workspace_poses": acc.poses,
            },
            "measurement": self.kind.value,
            "measurements": self.measurements,
            "seconds": self.seconds,
            "notes": list(self.notes),
        }
