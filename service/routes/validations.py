from __future__ import annotations

import functools
from typing import Any

from fastapi import APIRouter, Depends, Query, Request, Response

from service.compute import limits
from service.files.campaign_requests import (
    FileOptions,
    campaign_request,
    campaign_request_body,
    query_fields,
    robot_columns,
)
from service.http.deps import ComputeDep, DatabaseDep, RegistryDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import VALIDATION, Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.schemas.common import NOTES_MAX
from service.schemas.validations import (
    MAX_VERSIONS,
    IsoPosesCreate,
    IsoPosesPublic,
    ValidationCreate,
    ValidationPublic,
)
from service.services import validations

router = APIRouter(tags=["validations"], route_class=OffloopRoute)


def validation_fields(
    versions: list[int] | None = Query(
        None, max_length=MAX_VERSIONS, description="CSV and multipart bodies: the body's versions (repeatable)"
    ),
    register: bool | None = Query(None, description="CSV and multipart bodies: the body's register"),
    notes: str | None = Query(None, max_length=NOTES_MAX, description="CSV and multipart bodies: the body's notes"),
) -> dict[str, Any]:
    """What the query adds to a validation read from a file: the body's fields a file has no column for (None: not
    given)."""
    return {"versions": versions, "register": register, "notes": notes}


@router.post(
    "/v1/robots/{robot_id}/validations",
    status_code=201,
    response_model=ValidationPublic,
    openapi_extra=campaign_request_body(ValidationCreate),
)
@operation(Scope.write, runs=Runs.COMPUTE, precount=VALIDATION, tables=True)
async def create_validation(
    robot_id: str,
    request: Request,
    *,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    options: FileOptions,
    fields: dict[str, Any] = Depends(validation_fields),
) -> Response:
    """Measurements that are not fitted, against parameter versions: per-pose errors, RMS, max, percentiles, and
    ISO 9283 AP/RP (and AD/RD) where joint commands repeat. The records as JSON, or a campaign file as a
    calibration takes it (text/csv or multipart, the same query options)."""
    body = await campaign_request(
        request,
        ValidationCreate,
        options,
        query_fields(fields),
        functools.partial(robot_columns, db, robot_id),
    )
    # A large body was counted in its bytes (its precount); a small one can still ask for much (600 records × 50
    # versions), counted here, as a file once read. No job form: over the budget, fewer at a time.
    records = len(body.measurements)
    cost = limits.validation(records * len(body.versions or [None]), records)
    result = await compute.admitted(
        cost, "validation", validations.validate, db=db, registry=registry, robot_id=robot_id, body=body
    )
    return model_json(result, status_code=201)


robot_list(
    router, "/v1/robots/{robot_id}/validations", ValidationPublic, validations.list_validations, name="list_validations"
)


@router.get("/v1/validations/{validation_id}", response_model=ValidationPublic)
@operation(Scope.read)
def get_validation(validation_id: str, db: DatabaseDep) -> Response:
    return model_json(validations.get_validation(db=db, validation_id=validation_id))


@router.post("/v1/robots/{robot_id}/iso9283-poses", response_model=IsoPosesPublic)
@operation(Scope.read, runs=Runs.COMPUTE)  # computes the cube's commands, stores nothing
async def iso9283_poses(
    robot_id: str, db: DatabaseDep, registry: RegistryDep, compute: ComputeDep, body: IsoPosesCreate | None = None
) -> Response:
    """The ISO 9283 test cube inside the workspace (C1…C8, P1…P5) and the joint commands of P1…P5 from the
    chosen version (default: current). Measure P1…P5 in cycles and POST them as a validation."""
    chosen = body or IsoPosesCreate()
    result = await compute("iso9283", validations.iso_poses, db=db, registry=registry, robot_id=robot_id, body=chosen)
    return model_json(result)
