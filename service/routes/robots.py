from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Header, Query, Request, Response

from service.files.parameters_csv import PARAMETER_HEADER, parameters_csv
from service.http.deps import JSON_OR_CSV, ActorDep, BuildsDep, DatabaseDep, Limit, Offset, requested_media
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import model_json, models_json
from service.http.security import Scope
from service.schemas.robots import MAX_VERSION, ParametersPublic, RobotCreate, RobotPatch, RobotPublic
from service.schemas.structure import StructureDocument
from service.services import exports, robots
from service.services.exports import DH_MEDIA_TYPE

router = APIRouter(prefix="/v1/robots", tags=["robots"], route_class=OffloopRoute)
IfMatch = Annotated[str | None, Header(description="The robot's ETag as last read: 412 when it has changed since")]
_PRECONDITION: dict[int | str, dict[str, Any]] = {412: {"description": "If-Match is stale"}}
_PARAMETERS_CSV: dict[int | str, dict[str, Any]] = {
    200: {
        "content": {"text/csv": {"schema": {"type": "string", "description": "header " + ",".join(PARAMETER_HEADER)}}}
    },
    406: {"description": "Accept allows neither JSON nor CSV"},
}
_CONTROLLER_FORMATS = {
    DH_MEDIA_TYPE: {
        "schema": {"$ref": "#/components/schemas/DhTablePublic"},
        "description": "The DH/MDH table (?format=dh)",
    },
    "application/xml": {"schema": {"type": "string"}, "description": "URDF (?format=urdf)"},
    "application/yaml": {"schema": {"type": "string"}, "description": "UR's kinematics file (?format=ur-calibration)"},
}


def _etag(robot: RobotPublic) -> str:
    return f'"{robot.revision}"'


@router.post("", status_code=201, response_model=RobotPublic)
@operation(Scope.write)
def create_robot(body: RobotCreate, db: DatabaseDep, actor: ActorDep, builds: BuildsDep) -> Response:
    robot = robots.create_robot(db=db, body=body, actor=actor, builds=builds)
    return model_json(robot, status_code=201, etag=_etag(robot))


@router.get("", response_model=list[RobotPublic])
@operation(Scope.read)
def list_robots(
    db: DatabaseDep,
    limit: Limit = 100,
    offset: Offset = 0,
) -> Response:
    return models_json(robots.list_robots(db=db, limit=limit, offset=offset), RobotPublic)


@router.get("/{robot_id}", response_model=RobotPublic)
@operation(Scope.read)
def get_robot(robot_id: str, db: DatabaseDep, builds: BuildsDep) -> Response:
    robot = robots.get_robot(db=db, robot_id=robot_id, builds=builds)
    return model_json(robot, etag=_etag(robot))


@router.patch(
    "/{robot_id}",
    response_model=RobotPublic,
    responses={**_PRECONDITION, 409: {"description": "Another robot has that name"}},
)
@operation(Scope.write)
def patch_robot(
    robot_id: str,
    body: RobotPatch,
    db: DatabaseDep,
    actor: ActorDep,
    builds: BuildsDep,
    *,
    if_match: IfMatch = None,
) -> Response:
    robot = robots.patch_robot(db=db, robot_id=robot_id, body=body, actor=actor, if_match=if_match, builds=builds)
    return model_json(robot, etag=_etag(robot))


@router.delete("/{robot_id}", status_code=204, responses=_PRECONDITION)
@operation(Scope.admin)
def delete_robot(robot_id: str, db: DatabaseDep, actor: ActorDep, if_match: IfMatch = None) -> Response:
    robots.delete_robot(db=db, robot_id=robot_id, actor=actor, if_match=if_match)
    return Response(status_code=204)


@router.get(
    "/{robot_id}/parameters",
    response_model=ParametersPublic,
    responses={
        200: {
            "content": {
                **_PARAMETERS_CSV[200]["content"],
                **_CONTROLLER_FORMATS,
            }
        },
        **{k: v for k, v in _PARAMETERS_CSV.items() if k != 200},
    },
)
@operation(Scope.read)
def get_parameters(
    robot_id: str,
    request: Request,
    db: DatabaseDep,
    version: int | None = Query(None, ge=1, le=MAX_VERSION, description="A past version (default: current)"),
    format: Literal["json", "csv", "urdf", "dh", "ur-calibration"] | None = Query(
        None,
        description="Instead of Accept: 'csv'; or the calibrated arm as a controller reads it (docs/exports.md): "
        "'urdf' (an imported URDF comes back with its calibrated joint origins), 'dh' (the DH/MDH table with "
        "base and tool, JSON as DhTablePublic), 'ur-calibration' (UR's kinematics YAML, a "
        "6R arm). "
        "Each states its frame; a 422 names why a robot or version cannot be exported exactly (a parallel "
        "stage, model terms, not a 6R arm)",
    ),
) -> Response:
    """JSON or CSV by Accept (406 for anything else) or ?format=; either re-imports through POST
    …/parameter-versions. URDF, DH and UR's kinematics file for serial structures."""
    if format in ("urdf", "dh", "ur-calibration"):
        out = exports.export(db=db, robot_id=robot_id, version=version, format=format)
        return Response(content=out.content, media_type=out.media_type)
    media = requested_media(request, format, JSON_OR_CSV)
    parameters, etag = robots.get_parameters(db=db, robot_id=robot_id, version=version)
    if media == "text/csv":
        response = Response(parameters_csv(parameters), media_type="text/csv")
    else:
        response = model_json(parameters)
    response.headers["ETag"] = etag
    return response


@router.get("/{robot_id}/structure", response_model=StructureDocument)
@operation(Scope.read)
def get_structure(
    robot_id: str,
    db: DatabaseDep,
    version: int | None = Query(None, ge=1, le=2**31 - 1, description="A parameter version (default: current)"),
) -> Response:
    """The description document with the values of a parameter version; `POST /v1/robots` accepts it back."""
    return model_json(robots.get_structure(db=db, robot_id=robot_id, version=version))
