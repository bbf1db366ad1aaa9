"""The frozen outcome of an identification (internal units), and its boundary-unit (mm, deg) dictionary."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from models._types import Array
from models.description.parameters import ParameterTable
from models.identifiability import Confounding
from models.identification.diagnosis import Diagnosis
from models.identification.statistics import PoseErrors
from models.measurement import MeasurementKind
from models.measurements.references import AnyReference


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
    per_pose_xyz_mm: Array | None = None
    """(N, 3) measured minus model along x, y, z (the records' frame); None where records have no direction."""

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
            per_pose_xyz_mm=errors.position_xyz_mm,
        )

    @staticmethod
    def of_positions(per_record_mm: Array) -> ResidualSummary:
        """Of records that measure no orientation (a distance, a touch, a position), their errors in mm."""
        return ResidualSummary.of(PoseErrors(per_record_mm, None))


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

    @classmethod
    def at(
        cls, errors: PoseErrors, k: int, *, pose: int, statistic: float, threshold: float, excluded: bool
    ) -> Outlier:
        """Record `pose`, the `k`-th of `errors`, flagged by its `statistic` against `threshold`."""
        orientation = None if errors.orientation_rad is None else float(errors.orientation_rad[k])
        return cls(pose, float(errors.position_mm[k]), orientation, float(statistic), threshold, excluded)


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
    region_rms_position_mm: float = float("nan")
    """The same prediction at the campaign's own poses: what the calibration promises where it was measured."""
    region_max_position_mm: float = float("nan")
    region_record_rms_mm: float = float("nan")
    """What a fresh record in the measured region is predicted to differ from the calibrated model by (RMS of
    the position error): the region's model uncertainty and the records' own scatter as the fit's residuals show
    it (`models.identification.accuracy.with_record_scatter`). The figure a held-out campaign's error is judged
    against: on a real campaign the scatter (what the model does not describe, the instrument's noise) is most
    of it. NaN where the records are not positions in mm (distances, images)."""
    extrapolation: str | None = None
    """Why the workspace-wide figures are extrapolation (None when they agree with the measured region's)."""

    @staticmethod
    def undefined() -> PredictedAccuracy:
        nan = float("nan")
        return PredictedAccuracy(nan, nan, nan, nan, 0)


@dataclass(frozen=True)
class ReferenceEstimate:
    """One reference's unknowns as identified (internal units: mm, rad) with their standard errors."""

    reference: AnyReference
    """As the fit started it (its closed-form start)."""
    values: Array
    """Its unknowns at the solution, in `reference.unknowns` order."""
    std_errors: Array
    rms_residual_mm: float
    """Of its records at the solution, in its `traits.sigma_unit` (mm; a camera's px)."""
    records: int


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
    variance_interval: tuple[float, float]
    """The variance factor's acceptance interval (χ² at the statistics' consistency level); NaN without a fit."""
    outliers: tuple[Outlier, ...]
    solver: SolverReport
    predicted_accuracy: PredictedAccuracy
    kind: MeasurementKind
    measurements: int
    seconds: float
    notes: tuple[str, ...] = ()
    diagnoses: tuple[Diagnosis, ...] = ()
    """What the pre-fit checks found (models.identification.diagnosis); a blocking one means no fit was run.
    After a fit that fails its variance-factor test, also a missing temperature or load term (`terms_check`)."""
    missing: tuple[tuple[str, str], ...] = ()
    """(parameter, what to measure): the model terms' parameters the campaign's conditions cannot determine."""
    references: tuple[ReferenceEstimate, ...] = ()
    """A campaign against references (anchors, points, planes): each one's unknowns as identified."""
    frame: str | None = None
    """What the parameters are expressed in, where the records do not say it themselves (references fix no
    frame); None: the instrument's frame, registered as the base."""
    record_kinds: tuple[tuple[str, int], ...] = ()
    """(kind, records) of a campaign of several kinds: "distance", "point", "plane", "position"."""
    prediction_covariance: Array | None = None
    """The covariance a prediction at a fresh pose uses (internal units, `estimated` order): the fit's along the
    directions the records saw, one tolerance² along those they did not (left at their start); None: the fit
    gave none (use `covariance`). `models.identification.pose_accuracy` judges poses with it."""

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
