"""The thesis's tolerance study (§4.5): request and complete report, in mm and degrees."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from models.error_analysis import ErrorMagnitudes
from service.conversions.units import degrees_default
from service.schemas.common import OptionalFloat, Public, Strict

_DEFAULT = ErrorMagnitudes()
Distribution = Literal["sign", "uniform"]


class ErrorAnalysisRequest(Strict):
    robot_id: str | None = Field(
        default=None,
        max_length=64,
        description="The robot whose description is studied (its nominal geometry, any structure); "
        "absent: the nominal IWR, the thesis's study",
    )
    poses: int = Field(default=40, ge=1, le=2000, description="Random workspace poses (thesis: 40)")
    draws: int = Field(default=200, ge=1, le=5000, description="Error draws per pose")
    distribution: Distribution = "sign"
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    # Magnitudes per parameter kind, whatever the structure: every link's angles (theta, alpha, and beta where a
    # link has one) and lengths (a, d), every leg's offset and joint coordinates; base and tool are not perturbed.
    leg_offset_mm: float = Field(default=_DEFAULT.leg_offset, ge=0, le=100, description="Each leg's length offset")
    joint_position_mm: float = Field(
        default=_DEFAULT.joint_position, ge=0, le=100, description="Each coordinate of every hexapod joint (a_i, b_i)"
    )
    dh_angle_deg: float = Field(
        default=degrees_default(_DEFAULT.dh_angle),
        ge=0,
        le=10,
        description="Every link angle: theta (joint offset), alpha and Hayati's beta",
    )
    dh_length_mm: float = Field(
        default=_DEFAULT.dh_length,
        ge=0,
        le=100,
        description="Every link length: a and d (for a prismatic joint, its offset)",
    )


class AxesPublic(Public):
    x: OptionalFloat
    y: OptionalFloat
    z: OptionalFloat


class AxesSeriesPublic(Public):
    x: list[OptionalFloat]
    y: list[OptionalFloat]
    z: list[OptionalFloat]


class AbsolutePositionPublic(Public):
    rms_mm: float
    mean_mm: float
    p95_mm: float
    max_mm: float


class AbsoluteOrientationPublic(Public):
    rms_deg: float
    mean_deg: float
    p95_deg: float
    max_deg: float


class PositionStatsPublic(Public):
    """Per axis over poses and draws, and of the absolute error; worst case only for the TCP cases."""

    rms_mm: AxesPublic
    mean_abs_mm: AxesPublic
    max_abs_mm: AxesPublic
    absolute: AbsolutePositionPublic
    worst_case_abs_mm: AxesPublic | None = Field(default=None, exclude_if=lambda v: v is None)


class OrientationStatsPublic(Public):
    rms_deg: AxesPublic
    mean_abs_deg: AxesPublic
    max_abs_deg: AxesPublic
    absolute: AbsoluteOrientationPublic
    worst_case_abs_deg: AxesPublic | None = Field(default=None, exclude_if=lambda v: v is None)


class ModelStatsPublic(Public):
    position: PositionStatsPublic
    orientation: OrientationStatsPublic


class PositionGapPublic(Public):
    rms_mm: float
    max_mm: float
    relative_rms: float


class OrientationGapPublic(Public):
    rms_deg: float
    max_deg: float
    relative_rms: float


class GapPublic(Public):
    position: PositionGapPublic
    orientation: OrientationGapPublic


class CasePublic(Public):
    exact: ModelStatsPublic
    first_order: ModelStatsPublic
    linearisation_gap: GapPublic = Field(description="Exact minus first-order model")


class RatioPublic(Public):
    position: OptionalFloat
    orientation: OptionalFloat


class CarriageFramePublic(CasePublic):
    """The carriage end frame's own errors (the thesis's "carriage" curves)."""

    mean_abs_ratio_to_whole: RatioPublic


class SubsystemsPublic(Public):
    carriage: CasePublic
    hexapod: CasePublic
    whole: CasePublic


class SharePublic(Public):
    mean_abs_ratio: OptionalFloat
    variance_share: OptionalFloat


class SubsystemSharesPublic(Public):
    carriage: SharePublic
    hexapod: SharePublic


class QuantitySharesPublic(Public):
    position: SubsystemSharesPublic
    orientation: SubsystemSharesPublic


class SharesPublic(Public):
    exact: QuantitySharesPublic
    first_order: QuantitySharesPublic


class DominantAxisPublic(Public):
    carriage: Literal["x", "y", "z"]
    hexapod: Literal["x", "y", "z"]
    whole: Literal["x", "y", "z"]
    carriage_frame: Literal["x", "y", "z"]


class ThesisClaimsPublic(Public):
    """The thesis's three findings, measured here (exact model)."""

    carriage_frame_mean_abs_ratio_position: OptionalFloat
    carriage_mean_abs_ratio_position: OptionalFloat
    carriage_variance_share_position: OptionalFloat
    carriage_mean_abs_ratio_orientation: OptionalFloat
    carriage_variance_share_orientation: OptionalFloat
    dominant_position_axis: DominantAxisPublic
    max_position_error_mm: float
    median_over_draws_of_max_position_error_mm: float
    worst_case_position_axis_error_mm: float
    position_error_under_10_mm: bool
    worst_case_under_10_mm: bool


class PerPoseModelPublic(Public):
    position_rms_mm: list[float] = Field(description="RMS over the draws of |dp|, per pose")
    position_first_draw_mm: list[float]
    position_axes_rms_mm: AxesSeriesPublic
    orientation_rms_deg: list[float]
    orientation_first_draw_deg: list[float]
    orientation_axes_rms_deg: AxesSeriesPublic


class PerPoseCasePublic(Public):
    exact: PerPoseModelPublic
    first_order: PerPoseModelPublic


class PerPosePublic(Public):
    joints: list[list[float]] = Field(description="The poses, mm and deg")
    carriage: PerPoseCasePublic
    hexapod: PerPoseCasePublic
    whole: PerPoseCasePublic
    carriage_frame: PerPoseCasePublic


class TolerancesPublic(Public):
    leg_offset_mm: float
    joint_position_mm: float
    dh_angle_deg: float
    dh_length_mm: float


class ErrorAnalysisPublic(Public):
    robot: str
    n_poses: int
    n_draws: int
    seed: int
    distribution: Distribution
    tolerances: TolerancesPublic
    subsystems: SubsystemsPublic
    carriage_frame: CarriageFramePublic
    shares: SharesPublic
    superposition_gap: GapPublic = Field(description="Exact whole minus (carriage + hexapod): what is not additive")
    thesis_claims: ThesisClaimsPublic
    per_pose: PerPosePublic
    seconds: float
