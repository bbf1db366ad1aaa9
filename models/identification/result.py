"""The frozen outcome of an identification, and its boundary-unit (mm, deg) dictionary."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from models.identifiability import Confounding
from models.identification.statistics import PoseErrors
from models.kinematics import Array
from models.parameters import ParameterTable

DEG = float(np.degrees(1.0))


def _num(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


@dataclass(frozen=True)
class ResidualSummary:
    rms_mm: float
    max_mm: float
    rms_deg: float | None
    max_deg: float | None
    per_pose_mm: Array
    per_pose_deg: Array | None

    @staticmethod
    def of(errors: PoseErrors) -> ResidualSummary:
        pos = errors.position_mm
        rot = None if errors.orientation_rad is None else errors.orientation_rad * DEG
        return ResidualSummary(
            rms_mm=float(np.sqrt(np.mean(pos**2))),
            max_mm=float(pos.max()),
            rms_deg=None if rot is None else float(np.sqrt(np.mean(rot**2))),
            max_deg=None if rot is None else float(rot.max()),
            per_pose_mm=pos,
            per_pose_deg=rot,
        )

    def to_dict(self, per_pose: bool = True) -> dict[str, Any]:
        out: dict[str, Any] = {"rms_mm": self.rms_mm, "max_mm": self.max_mm}
        if self.rms_deg is not None:
            out |= {"rms_deg": self.rms_deg, "max_deg": self.max_deg}
        if per_pose:
            out["per_pose_mm"] = self.per_pose_mm.tolist()
            if self.per_pose_deg is not None:
                out["per_pose_deg"] = self.per_pose_deg.tolist()
        return out


@dataclass(frozen=True)
class Outlier:
    pose: int
    position_mm: float
    orientation_deg: float | None
    statistic: float
    """Σ of the pose's squared standardised residuals (≈ χ² with 3 or 6 degrees of freedom when clean)."""
    threshold: float
    excluded: bool


@dataclass(frozen=True)
class SolverReport:
    name: str
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float
    evaluations: int
    polish_steps: int = 0
    """Gauss–Newton steps taken after IPOPT (see identify._polish)."""


@dataclass(frozen=True)
class PredictedAccuracy:
    """1-σ TCP uncertainty over sampled workspace poses, from the a-posteriori covariance."""

    rms_position_mm: float
    max_position_mm: float
    rms_orientation_deg: float
    max_orientation_deg: float
    poses: int


@dataclass(frozen=True)
class IdentificationResult:
    status: str
    """"succeeded" or "failed"; a failed result must never be applied to a robot."""
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
    position_only: bool
    measurements: int
    seconds: float
    notes: tuple[str, ...] = ()

    @property
    def succeeded(self) -> bool:
        return self.status == "succeeded"

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
            "status": self.status,
            "reason": self.reason,
            "parameters": [
                {
                    "name": name,
                    "value": float(value[i]),
                    "unit": t.units[i],
                    "nominal": float(nominal[i]),
                    "std_error": _num(std[i]) if i in chosen else None,
                    "identifiable": i in chosen,
                }
                for i, name in enumerate(t.names)
            ],
            "identifiable": list(self.identifiable_names),
            "unidentifiable": list(self.unidentifiable_names),
            "confounding": {c.name: [{"with": p, "coefficient": k} for p, k in c.partners] for c in self.confounding},
            "correlated_pairs": [{"a": a, "b": b, "correlation": r} for a, b, r in self.correlated_pairs],
            "rank": self.rank,
            "condition_number": _num(self.condition_number),
            "identifiability_rechecked": self.identifiability_rechecked,
            "residuals": {
                "before": self.residuals_before.to_dict(per_pose),
                "after": self.residuals_after.to_dict(per_pose),
            },
            "variance_factor": _num(self.variance_factor),
            "degrees_of_freedom": self.dof,
            "noise_consistent": self.noise_consistent,
            "outliers": [
                {
                    "pose": o.pose,
                    "position_mm": o.position_mm,
                    "orientation_deg": o.orientation_deg,
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
                "rms_position_mm": _num(acc.rms_position_mm),
                "max_position_mm": _num(acc.max_position_mm),
                "rms_orientation_deg": _num(acc.rms_orientation_deg),
                "max_orientation_deg": _num(acc.max_orientation_deg),
                "workspace_poses": acc.poses,
            },
            "measurement": "position" if self.position_only else "pose",
            "measurements": self.measurements,
            "seconds": self.seconds,
            "notes": list(self.notes),
        }
