from __future__ import annotations

from typing import Annotated, Any

import anyio
from fastapi import APIRouter, Path, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import ValidationError

from service.errors import BadRequest, UnsupportedMediaType
from service.files.parameters_csv import PARAMETER_HEADER, parse_parameters
from service.http.deps import ActorDep, DatabaseDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import model_json, models_json
from service.http.security import Scope
from service.routes.robots import IfMatch
from service.schemas.versions import ParameterVersionImport, ParameterVersionPublic, VersionDiffPublic
from service.services import versions

router = APIRouter(
    prefix="/v1/robots/{robot_id}/parameter-versions", tags=["parameter versions"], route_class=OffloopRoute
)
Version = Annotated[int, Path(ge=1, le=2**31 - 1)]
_PRECONDITION: dict[int | str, dict[str, Any]] = {412: {"description": "If-Match is stale"}}
_IMPORT_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": {"$ref": "#/components/schemas/ParameterVersionImport"}},
            "text/csv": {"schema": {"type": "string", "description": "header " + ",".join(PARAMETER_HEADER)}},
        },
    }
}


@router.get("", response_model=list[ParameterVersionPublic])
@operation(Scope.read)
def list_versions(robot_id: str, db: DatabaseDep) -> Response:
    """Oldest first; the ETag is the robot's (If-Match of a restore)."""
    rows, etag = versions.list_versions(db=db, robot_id=robot_id)
    return models_json(rows, ParameterVersionPublic, etag=etag)


@router.get("/{a}/diff/{b}", response_model=VersionDiffPublic)
@operation(Scope.read)
def diff_versions(robot_id: str, db: DatabaseDep, a: Version, b: Version) -> Response:
    return model_json(versions.diff(db=db, robot_id=robot_id, a=a, b=b))


@router.post("/{version}/restore", status_code=201, response_model=ParameterVersionPublic, responses=_PRECONDITION)
@operation(Scope.admin)  # restoring makes another version current, as deleting discards
def restore_version(
    robot_id: str, db: DatabaseDep, actor: ActorDep, version: Version, if_match: IfMatch = None
) -> Response:
    """A new current version equal to `version`; nothing is deleted or overwritten."""
    row, etag = versions.restore(db=db, robot_id=robot_id, version=version, actor=actor, if_match=if_match)
    return model_json(row, status_code=201, etag=etag)


async def _import_body(request: Request) -> ParameterVersionImport:
    content_type = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    raw = await request.body()
    try:
        if content_type == "text/csv":
            try:
                text = raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise BadRequest("the CSV body must be UTF-8 text") from exc
            return ParameterVersionImport.model_validate(parse_parameters(text))
        if content_type in ("application/json", ""):
            return ParameterVersionImport.model_validate_json(raw or b"null")
    except ValidationError as exc:
        raise RequestValidationError(exc.errors(include_url=False, include_context=False)) from exc
    raise UnsupportedMediaType(
        f"send the parameters as application/json or text/csv, not {content_type!r}", content_type=content_type
    )


@router.post(
    "", status_code=201, response_model=ParameterVersionPublic, responses=_PRECONDITION, openapi_extra=_IMPORT_BODY
)
@operation(Scope.admin, tables=True)  # importing makes another version current
async def import_version(
    robot_id: str, request: Request, db: DatabaseDep, actor: ActorDep, if_match: IfMatch = None
) -> Response:
    """The parameters export (GET …/parameters, JSON or CSV) as a new current version: how an export re-imports."""
    body = await _import_body(request)
    row, etag = await anyio.to_thread.run_sync(
        lambda: versions.import_version(db=db, robot_id=robot_id, body=body, actor=actor, if_match=if_match)
    )
    return model_json(row, status_code=201, etag=etag)
