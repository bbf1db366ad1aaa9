from __future__ import annotations

from fastapi import APIRouter, Response

from service.compute import limits
from service.http.deps import ComputeDep, ModelCacheDep, RegistryDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest
from service.services import error_analysis

router = APIRouter(tags=["error analysis"], route_class=OffloopRoute)


@router.post(
    "/v1/error-analysis",
    response_model=ErrorAnalysisPublic,
    responses={404: {"description": "No robot has the body's robot_id"}},
)
@operation(Scope.read, runs=Runs.COMPUTE)
async def run_error_analysis(
    body: ErrorAnalysisRequest, registry: RegistryDep, compute: ComputeDep, models: ModelCacheDep
) -> Response:
    """The tolerance study on the IWR, or on the robot `robot_id` names (any structure)."""
    cost = limits.error_analysis(body.poses, body.draws)
    analysis = await compute.admitted(
        cost, "error_analysis", error_analysis.analyse, registry=registry, body=body, models=models
    )
    return model_json(analysis)
