from __future__ import annotations

from fastapi import APIRouter, Response

from service import limits
from service.deps import MetricsDep, compute
from service.responses import model_json
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest
from service.services import error_analysis

router = APIRouter(tags=["error analysis"])


@router.post("/v1/error-analysis", response_model=ErrorAnalysisPublic)
async def run_error_analysis(body: ErrorAnalysisRequest, m: MetricsDep) -> Response:
    limits.admit(limits.error_analysis(body.poses, body.draws), run_async=False, can_run_async=False)
    return model_json(await compute(m, "error_analysis", error_analysis.analyse, body=body))
