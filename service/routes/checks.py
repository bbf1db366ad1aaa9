from __future__ import annotations

import functools
from typing import Any

from fastapi import APIRouter, Depends, Query, Request, Response

from service.compute import limits
from service.conversions.checks import HISTORY_COLUMNS, history_csv
from service.files.campaign_requests import (
    FileOptions,
    campaign_request,
    campaign_request_body,
    query_fields,
    robot_columns,
)
from service.http.deps import JSON_OR_CSV, ComputeDep, DatabaseDep, Limit, Offset, RegistryDep, requested_media
from service.http.json_bodies import OffloopRoute
from service.http.operations import QUICK_CHECK, Runs, operation
from service.http.responses import model_json, models_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.schemas.checks import (
    Against,
    HistoryEventPublic,
    QuickCheckCreate,
    QuickCheckDesignCreate,
    QuickCheckDesignPublic,
    QuickCheckPublic,
)
from service.schemas.common import NOTES_MAX
from service.services import checks

router = APIRouter(tags=["checks"], route_class=OffloopRoute)
_HISTORY_CSV: dict[int | str, dict[str, Any]] = {
    200: {
        "content": {"text/csv": {"schema": {"type": "string", "description": "header: " + ",".join(HISTORY_COLUMNS)}}}
    },
    406: {"description": "Accept allows neither JSON nor CSV"},
}


def check_fields(  # one FastAPI dependency: a Query declaration per body field a file has no column for
    *,
    noise_position_mm: float | None = Query(None, gt=0, le=1000, description="CSV and multipart bodies: noise's"),
    noise_orientation_deg: float | None = Query(None, gt=0, le=180, description="CSV and multipart bodies: noise's"),
    alpha: float | None = Query(None, gt=0, lt=0.5, description="CSV and multipart bodies: the body's alpha"),
    register: bool | None = Query(None, description="CSV and multipart bodies: the body's register"),
    against: Against | None = Query(None, description="CSV and multipart bodies: the body's against"),
    notes: str | None = Query(None, max_length=NOTES_MAX, description="CSV and multipart bodies: the body's notes"),
) -> dict[str, Any]:
    """What the query adds to a quick check read from a file: the body's fields a file has no column for (None:
    not given)."""
    noise = {"position_mm": noise_position_mm, "orientation_deg": noise_orientation_deg}
    given_noise = {k: v for k, v in noise.items() if v is not None} or None
    return {"noise": given_noise, "alpha": alpha, "register": register, "against": against, "notes": notes}


@router.post(
    "/v1/robots/{robot_id}/checks",
    status_code=201,
    response_model=QuickCheckPublic,
    openapi_extra=campaign_request_body(QuickCheckCreate),
)
@operation(Scope.write, runs=Runs.COMPUTE, precount=QUICK_CHECK, tables=True)
async def create_check(
    robot_id: str,
    request: Request,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    *,
    options: FileOptions,
    fields: dict[str, Any] = Depends(check_fields),
) -> Response:
    """A quick check (docs/checks.md): a few tracker records against the current version, tested against its
    predicted uncertainty at the false-alarm rate `alpha`; the verdict (fine, drifted, changed), what best
    explains a change, and what to do. The records as JSON, or a campaign file as a calibration takes it
    (text/csv or multipart, the same query options)."""
    body = await campaign_request(
        request, QuickCheckCreate, options, query_fields(fields), functools.partial(robot_columns, db, robot_id)
    )
    cost = limits.quick_check(len(body.measurements))
    result = await compute.admitted(
        cost, "check", checks.create_check, db=db, registry=registry, robot_id=robot_id, body=body
    )
    return model_json(result, status_code=201)


@router.post("/v1/robots/{robot_id}/checks/design", response_model=QuickCheckDesignPublic)
@operation(Scope.read, runs=Runs.COMPUTE)  # computes the poses, stores nothing
async def design_check(
    robot_id: str,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    body: QuickCheckDesignCreate | None = None,
) -> Response:
    """The poses of a check that see the likely changes best (the joint offsets, the tool), and the change of
    each the check would flag with 95 % probability."""
    chosen = body or QuickCheckDesignCreate()
    result = await compute(
        "check_design", checks.design_check_poses, db=db, registry=registry, robot_id=robot_id, body=chosen
    )
    return model_json(result)


robot_list(router, "/v1/robots/{robot_id}/checks", QuickCheckPublic, checks.list_checks, name="list_checks")


@router.get("/v1/checks/{check_id}", response_model=QuickCheckPublic)
@operation(Scope.read)
def get_check(check_id: str, db: DatabaseDep) -> Response:
    return model_json(checks.get_check(db=db, check_id=check_id))


@router.get("/v1/robots/{robot_id}/history", response_model=list[HistoryEventPublic], responses=_HISTORY_CSV)
@operation(Scope.read)
def history(
    robot_id: str,
    *,
    request: Request,
    db: DatabaseDep,
    limit: Limit = 100,
    offset: Offset = 0,
    format: str | None = Query(None, pattern="^(json|csv)$", description="Overrides Accept"),
) -> Response:
    """The robot's calibrations and checks on one timeline, oldest first, with the accuracy measured then: JSON,
    or CSV to export."""
    media = requested_media(request, format, JSON_OR_CSV)
    events = checks.history(db=db, robot_id=robot_id, limit=limit, offset=offset)
    if media == "text/csv":
        return Response(
            history_csv(events),
            media_type="text/csv",
            headers={"content-disposition": f'attachment; filename="history-{robot_id}.csv"'},
        )
    return models_json(events, HistoryEventPublic)
