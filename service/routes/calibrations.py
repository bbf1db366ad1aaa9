from __future__ import annotations

import functools
from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request, Response

from service.compute import limits
from service.files.campaign_requests import (
    CampaignQuery,
    campaign_body,
    campaign_query,
    campaign_request_body,
    robot_columns,
)
from service.http.deps import ActorDep, ComputeDep, DatabaseDep, JobsDep, RegistryDep, negotiate
from service.http.json_bodies import OffloopRoute
from service.http.operations import CALIBRATION, Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.routes.robots import IfMatch
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic
from service.services import calibrations
from service.services.jobs import submit_job

router = APIRouter(tags=["calibrations"], route_class=OffloopRoute)

_BODY = {
    **campaign_request_body(CalibrationCreate),
    "responses": {
        "202": {
            "description": "Accepted as a job (?async=true)",
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/JobAccepted"}}},
        },
        "406": {"description": "The Accept header allows no JSON (a calibration is a JSON document)"},
        "412": {"description": "If-Match is stale"},
        "429": {"description": "Job queue full"},
    },
}


def _json_answer(request: Request) -> None:
    """Refuse up front (406) a client that cannot read the JSON answer, before any computation."""
    negotiate(request, ["application/json", "application/problem+json"])


@router.post(
    "/v1/robots/{robot_id}/calibrations",
    status_code=201,
    response_model=CalibrationPublic,
    openapi_extra=_BODY,
    dependencies=[Depends(_json_answer)],
)
@operation(Scope.write, runs=Runs.COMPUTE, precount=CALIBRATION, job="calibration", tables=True)
async def create_calibration(
    robot_id: str,
    request: Request,
    db: DatabaseDep,
    jobs: JobsDep,
    compute: ComputeDep,
    *,
    registry: RegistryDep,
    actor: ActorDep,
    run_async: bool = Query(False, alias="async", description="Run as a job: 202 with a job id"),
    query: Annotated[CampaignQuery, Depends(campaign_query)],
    if_match: IfMatch = None,
) -> Response:
    # A JSON body over the budget was refused before any parsing (its `precount`, service.http.operations); a CSV one is
    # counted once parsed.
    body = await campaign_body(request, query, functools.partial(robot_columns, db, robot_id))
    compute.admit(limits.calibration(len(body.measurements)), run_async=run_async)
    if run_async:
        accepted = submit_job(
            db=db, jobs=jobs, kind="calibration", robot_id=robot_id, body=body, actor=actor, if_match=if_match
        )
        return model_json(accepted, status_code=202)
    calibration = await compute(
        "identification",
        calibrations.calibrate,
        db=db,
        registry=registry,
        robot_id=robot_id,
        body=body,
        actor=actor,
        if_match=if_match,
    )
    return model_json(calibration, status_code=201)


robot_list(
    router,
    "/v1/robots/{robot_id}/calibrations",
    CalibrationPublic,
    calibrations.list_calibrations,
    name="list_calibrations",
)


@router.get(
    "/v1/calibrations/{calibration_id}",
    response_model=CalibrationPublic,
    responses={406: {"description": "The Accept header allows no JSON (its campaign as CSV: /v1/campaigns/{id})"}},
)
@operation(Scope.read)
def get_calibration(calibration_id: str, request: Request, db: DatabaseDep) -> Response:
    # A calibration is a JSON document (its campaign has a CSV form: GET /v1/campaigns/{id}); 406 for anything
    # else rather than JSON a CSV client cannot read.
    negotiate(request, ["application/json"])
    return model_json(calibrations.get_calibration(db=db, calibration_id=calibration_id))
