"""Calibration requests and the complete calibration report (boundary units: mm, degrees)."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import ConfigDict, Field

from models.identification import IdentificationOptions, RobustLoss
from models.identification.drift import MAX_DEGREE, DriftDriver
from models.identification.options import DEFAULT_GROUPS
from models.noise import NoiseModel
from service.conversions.units import degrees_default
from service.record_kinds import CampaignRecord, ReferenceDescriptions, ReferencePublic
from service.schemas.common import (
    ConditionsPublic,
    FreeText,
    ImportNotes,
    Measurement,
    OptionalFloat,
    Payload,
    Public,
    Strict,
    absent_if_none,
    optional,
)
from service.schemas.fleets import FLEET_KEY, FleetComparisonPublic
from service.schemas.robots import ParameterPublic

_NOISE = NoiseModel()
_OPTIONS = IdentificationOptions()
MAX_MEASUREMENTS = 100_000


class Noise(Strict):
    position_mm: float = Field(default=_NOISE.position_mm, gt=0, le=1000)
    orientation_deg: float = Field(default=degrees_default(_NOISE.orientation_rad), gt=0, le=180)


class CalibrationOptions(Strict):
    estimate: list[str] = Field(
        default_factory=lambda: list(DEFAULT_GROUPS), min_length=1, description="Groups or parameter names"
    )
    robust: RobustLoss = Field(
        default=_OPTIONS.robust,
        description="auto: plain least squares, and a robust refit that excludes gross errors only when the χ² "
        "test finds any; none: plain least squares (outliers only flagged); huber / soft_l1: robust from the start",
    )
    robust_scale: float = Field(default=_OPTIONS.robust_scale, gt=0, le=1000, description="In units of σ")
    terms: list[Literal["thermal", "compliance"]] = Field(
        default_factory=list,
        max_length=2,
        description="Model terms beyond geometry: thermal (κ of the legs and prismatic axes, ppm/K; records need "
        "temperature_c) and compliance (per leg, µm/N; needs a payload); their parameters are estimated",
    )
    prior: Literal["none", "fleet"] = Field(
        default="none",
        description="fleet: calibrate with the population of the robot's fleet (the other calibrated robots of its "
        "structure document, GET /v1/robots/{id}/fleet) as prior (maximum a posteriori): fewer poses reach the "
        "same accuracy. Refused (422 fleet-too-small) while the fleet has too few calibrated units; tracker "
        "records only",
    )
    fleet: str | None = Field(
        default=None,
        pattern=FLEET_KEY,
        description="With prior fleet: the fleet expected (its key); a robot of another fleet is refused (422 "
        "prior-mismatch) rather than calibrated with another model's population. Default: the robot's own",
    )
    drift: DriftRequest | None = optional(
        "Fit and remove the instrument's drift over the campaign, seen on a reference pose measured "
        "every few records (tracker records only); null: none"
    )


class DriftRequest(Strict):
    """Fit the instrument's drift over the campaign and remove it (docs/drift.md)."""

    driver: DriftDriver = Field(
        default=DriftDriver.TIME,
        description="time: over the records' time (their order where they carry none); temperature: over their "
        "temperature_c (the instrument's frame moving with the hall's temperature)",
    )
    degree: int = Field(
        default=1, ge=1, le=MAX_DEGREE, description="Of the drift's polynomial per axis (1: a constant rate)"
    )


class Instrument(Strict):
    name: str = Field(min_length=1, max_length=200, examples=["Leica AT960"])
    serial: str | None = Field(default=None, max_length=200)


class InstrumentPublic(Public):
    name: str
    serial: str | None


class CalibrationCreate(ReferenceDescriptions):
    measurements: list[CampaignRecord] = Field(min_length=1, max_length=MAX_MEASUREMENTS)
    noise: Noise = Noise()
    apply: bool = True
    import_notes: ImportNotes
    force_apply: bool = Field(
        default=False,
        description="Apply even if a check fails (the variance-factor test, the identifiable count, accuracy "
        "against the start version); recorded with the calibration. A failed fit is never applied.",
    )
    options: CalibrationOptions = CalibrationOptions()
    payload: Payload | None = optional(
        "The campaign's payload (records may carry their own); used by the compliance term"
    )
    start_version: int | None = Field(
        default=None,
        ge=1,
        le=2**31 - 1,
        description="Parameter version the fit starts from (default: the robot's current one); the parameters "
        "it does not estimate keep this version's values",
    )
    notes: FreeText | None = optional("Free text, kept with the calibration")
    instrument: Instrument | None = optional("The instrument that measured the campaign")


# ------------------------------------------------------------------ the report


class CalibratedParameterPublic(ParameterPublic):
    identifiable: bool  # a calibration always knows
    start: OptionalFloat = optional(
        "The value the fit started from (the start version's); "
        "null in calibrations stored before start versions existed"
    )


class ConfoundingPartnerPublic(Public):
    model_config = ConfigDict(extra="forbid", populate_by_name=True, serialize_by_alias=True)
    with_: str = Field(alias="with", description="An identifiable parameter")
    coefficient: float


class CorrelatedPairPublic(Public):
    a: str
    b: str
    correlation: float


class ResidualsPublic(Public):
    """Per-pose TCP residuals; the orientation keys are absent for a position-only campaign."""

    rms_mm: float
    max_mm: float
    rms_deg: float | None = absent_if_none()
    max_deg: float | None = absent_if_none()
    per_pose_mm: list[float]
    per_pose_deg: list[float] | None = absent_if_none()
    rms_xyz_mm: list[OptionalFloat] | None = absent_if_none(
        "RMS of the error along x, y, z (measured minus model, the records' frame); tracker records",
    )
    per_pose_xyz_mm: list[list[OptionalFloat]] | None = absent_if_none(
        "Each record's error along x, y, z (measured minus model)"
    )


class ResidualsBeforeAfterPublic(Public):
    before: ResidualsPublic = Field(description="At the registered start")
    after: ResidualsPublic


class OutlierPublic(Public):
    pose: int
    position_mm: float
    orientation_deg: float | None
    statistic: float = Field(description="Σ of the pose's squared standardised residuals")
    threshold: float
    excluded: bool


class SolverReportPublic(Public):
    name: str
    status: str
    success: bool
    iterations: int
    seconds: float
    evaluations: int
    polish_steps: int = Field(description="Gauss–Newton steps after IPOPT")


class PredictedAccuracyPublic(Public):
    """1-σ TCP uncertainty over sampled workspace poses, from the a-posteriori covariance."""

    rms_position_mm: OptionalFloat
    max_position_mm: OptionalFloat
    rms_orientation_deg: OptionalFloat
    max_orientation_deg: OptionalFloat
    workspace_poses: int
    measured_region_rms_position_mm: OptionalFloat = optional(
        "The same 1-σ prediction at the campaign's own poses: what the calibration promises where it "
        "was measured (null for calibrations stored before it was reported)"
    )
    measured_region_max_position_mm: OptionalFloat = None
    measured_region_record_rms_mm: OptionalFloat = optional(
        "What a fresh record in the measured region is predicted to differ from the calibrated model "
        "by (RMS position error, mm): the region's 1-σ prediction and the records' own scatter as the residuals "
        "show it. The figure to judge a held-out campaign of the same region against; null where the records are "
        "not positions (distances, images) and for calibrations stored before it was reported"
    )
    extrapolation: str | None = optional(
        "Set when the workspace-wide figures exceed the measured region's by more than 3×: why, and "
        "where was measured; poses away from that region are extrapolation"
    )


class DiagnosisPublic(Public):
    finding: Literal[
        "radians",
        "length_scale",
        "reflection",
        "quaternion_order",
        "orientation_flip",
        "far_records",
        "mismatch",
        "temperature_term",
        "load_term",
        "other_plane",
        "tool_orientation",
        "joint_convention",
    ] = Field(
        description="temperature_term / load_term: after a fit, the residuals follow the records' conditions; "
        "other_plane: some touches of a plane lie on another face; tool_orientation (not blocking): the records' "
        "orientations differ from the robot's by one constant tool-side rotation, which the fit starts from; "
        "joint_convention: one joint's readings fit negated or shifted by ±90°/180° (a sign or zero convention)"
    )
    message: str
    records: list[int] = Field(description="The records concerned (0-based); empty: the whole campaign")
    blocking: bool = Field(description="No fit can succeed until it is fixed")


class CheckPublic(Public):
    name: Literal["fit", "noise", "identifiable", "residuals", "accuracy"]
    passed: bool
    detail: str
    blocks_apply: bool = Field(
        default=True,
        description="Whether failing this check keeps the calibration from being applied; the noise check never "
        "does (a stated σ the residuals contradict is reported, with σ estimated from them, and the result applied)",
    )


class NoisePublic(Public):
    position_mm: float
    orientation_deg: float


class CorrelationPublic(Public):
    """Correlation matrix of the estimated parameters, from the a-posteriori covariance."""

    names: list[str] = Field(description="The estimated parameters, in the matrix's order")
    matrix: list[list[OptionalFloat]]


class ScatterPublic(Public):
    before_mm: float
    after_mm: float


class DriftPublic(Public):
    """The instrument's drift fitted over the campaign and removed from the records before the parameters."""

    driver: DriftDriver
    degree: int
    over: Literal["seconds", "records", "temperature_c"] = Field(
        description="What the drift is a function of: the records' time (s), their order, or their temperature"
    )
    span: list[float] = Field(description="The driver's first and last value (s from the first record, index, °C)")
    over_campaign_mm: list[float] = Field(description="x, y, z: the drift from the span's start to its end")
    over_campaign_sigma_mm: list[OptionalFloat] = Field(description="Its 1-σ uncertainty per axis")
    magnitude_mm: float = Field(description="|over_campaign_mm|")
    rate_mm_per_h: list[float] | None = Field(description="x, y, z: the mean rate over the campaign (time stamps)")
    rate_mm_per_k: list[float] | None = Field(description="x, y, z: the mean rate per kelvin (temperature)")
    coefficients_mm: list[list[float]] = Field(
        description="Per axis x, y, z: the coefficients of u, u² … (u = the driver scaled to −1 … 1 over the span)"
    )
    reference_records: list[int] = Field(description="The records of the reference pose (0-based)")
    reference_scatter: ScatterPublic = Field(
        description="RMS distance of the reference pose's measured positions from their mean, as measured and "
        "with the drift removed (what remains is the instrument's noise)"
    )
    rounds: int = Field(description="Fits of the parameters (each with the drift of the round before removed)")


class CalibrationReportPublic(Public):
    """What a calibration computed: stored once, as validated here, and served as stored."""

    status: Literal["succeeded", "failed"]
    reason: str | None
    parameters: list[CalibratedParameterPublic]
    identifiable: list[str]
    unidentifiable: list[str]
    confounding: dict[str, list[ConfoundingPartnerPublic]] = Field(
        description="Per unidentifiable parameter: the identifiable ones its column is a combination of"
    )
    correlated_pairs: list[CorrelatedPairPublic]
    rank: int
    condition_number: OptionalFloat
    identifiability_rechecked: bool
    residuals: ResidualsBeforeAfterPublic
    variance_factor: OptionalFloat
    degrees_of_freedom: int
    noise_consistent: bool
    outliers: list[OutlierPublic]
    solver: SolverReportPublic
    predicted_accuracy: PredictedAccuracyPublic
    measurement: Measurement
    measurements: int
    seconds: float
    notes: list[str]
    start_version: int | None
    diagnoses: list[DiagnosisPublic] = Field(
        default_factory=list, description="What the checks before the fit found (a blocking one: no fit was run)"
    )
    checks: list[CheckPublic] = Field(
        default_factory=list, description="The checks a result must pass before it is applied"
    )
    not_applied_reason: str | None = optional("Why `apply` was asked and the result not applied (the failed checks)")
    forced: bool = Field(default=False, description="Applied although a check failed (force_apply), recorded")
    correlation: CorrelationPublic | None = optional("Null for calibrations stored before it was kept")
    noise: NoisePublic | None = optional("The measurement noise the fit assumed; null for calibrations stored before")
    references: list[ReferencePublic] = Field(
        default_factory=list,
        description="The anchors, points and planes the records measured, as identified with the robot",
    )
    frame: str | None = optional(
        "What the parameters and references are expressed in, where the records fix no frame "
        "(distances, points, planes); null: the instrument's frame, registered as the base"
    )
    record_kinds: dict[str, int] | None = optional("Records per kind of a campaign with any but tracker records")
    drift: DriftPublic | None = optional("The instrument's drift fitted and removed (options.drift); null: none asked")
    conditions: ConditionsPublic | None = optional(
        "What the campaign was measured under (stored with the version it makes); null before kept"
    )
    fleet: FleetComparisonPublic | None = optional(
        "This unit against the population of its fleet's other calibrated units (z-scores, outlier); "
        "null while the fleet has too few of them"
    )


class CalibrationPublic(CalibrationReportPublic):
    id: str
    robot_id: str
    campaign_id: str
    applied: bool
    parameter_version: int | None = Field(description="The version this calibration created (when applied)")
    created_at: datetime
    user_notes: str | None = optional("The free-text notes sent with the request")
    instrument: InstrumentPublic | None = None
