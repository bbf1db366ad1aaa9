"""The tolerance study: the request's magnitudes in internal units, and the frozen `ErrorAnalysisResult`
summarised as the report (statistics over poses and draws, mm and degrees)."""

from __future__ import annotations

from models.error_analysis import ErrorAnalysisResult, ErrorMagnitudes
from models.error_analysis.export import result_json
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest


def tolerances_in(body: ErrorAnalysisRequest) -> ErrorMagnitudes:
    return ErrorMagnitudes.from_boundary(
        leg_offset_mm=body.leg_offset_mm,
        joint_position_mm=body.joint_position_mm,
        dh_angle_deg=body.dh_angle_deg,
        dh_length_mm=body.dh_length_mm,
    )


def report_out(result: ErrorAnalysisResult) -> ErrorAnalysisPublic:
    """The study's summary in mm and degrees: the same document the command line writes (`result_json`), so the
    API and the file cannot drift apart."""
    return ErrorAnalysisPublic.model_validate(result_json(result))
