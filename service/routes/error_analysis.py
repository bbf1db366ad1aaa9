from __future__ import annotations

from typing import Any, Literal

from fastapi import APIRouter, Request
from pydantic import Field, model_validator

from models import iwr
from models.error_analysis import MAX_EVALUATIONS as STUDY_MAX_EVALUATIONS
from models.error_analysis import ErrorMagnitudes, error_analysis
from service.routes.deps import compute
from service.schemas.common import Strict

router = APIRouter(tags=["error analysis"])
# A request runs synchronously on the compute pool, so it gets 40 % of the study's own cap: 40 000
# poses × draws take ~3 s here (the model's 100 000, ~7 s, stays for the CLI and library calls).
MAX_EVALUATIONS = STUDY_MAX_EVALUATIONS * 2 // 5


class ErrorAnalysisRequest(Strict):
    poses: int = Field(default=40, ge=1, le=2000, description="Random workspace poses (thesis: 40)")
    draws: int = Field(default=200, ge=1, le=5000, description="Error draws per pose")
    distribution: Literal["sign", "uniform"] = "sign"
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    leg_offset_mm: float = Field(default=0.5, ge=0, le=100)
    joint_position_mm: float = Field(default=0.1, ge=0, le=100)
    dh_angle_deg: float = Field(default=0.1, ge=0, le=10)
    dh_length_mm: float = Field(default=0.5, ge=0, le=100)

    @model_validator(mode="after")
    def _bounded(self) -> ErrorAnalysisRequest:
        if self.poses * self.draws > MAX_EVALUATIONS:
            raise ValueError(f"poses × draws must stay within {MAX_EVALUATIONS} (a synchronous request)")
        return self


@router.post("/v1/error-analysis")
async def run_error_analysis(body: ErrorAnalysisRequest, request: Request) -> dict[str, Any]:
    tolerances = ErrorMagnitudes.from_boundary(
        leg_offset_mm=body.leg_offset_mm,
        joint_position_mm=body.joint_position_mm,
        dh_angle_deg=body.dh_angle_deg,
        dh_length_mm=body.dh_length_mm,
    )

    def run() -> dict[str, Any]:
        result = error_analysis(
            iwr(),
            n_poses=body.poses,
            n_draws=body.draws,
            tolerances=tolerances,
            distribution=body.distribution,
            seed=body.seed,
        )
        return result.to_dict()

    return await compute(request, "error_analysis", run)
