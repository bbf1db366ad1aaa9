"""A robot's cell: PUT a new version, GET the current one (or a past one) with its effective geometry, its
versions, DELETE (ends it; a version records that), and a check of poses against it."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Header, Query, Response

from service.compute import limits
from service.http.deps import ActorDep, ComputeDep, DatabaseDep, ModelCacheDep, RegistryDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.schemas.cells import CellCheckCreate, CellCheckPublic, CellDocument, CellPublic, CellVersionPublic
from service.services import cells

router = APIRouter(prefix="/v1/robots/{robot_id}/cell", tags=["cells"], route_class=OffloopRoute)
IfMatch = Annotated[str | None, Header(description="The robot's ETag as last read: 412 when it has changed since")]
_PRECONDITION: dict[int | str, dict[str, Any]] = {412: {"description": "If-Match is stale"}}
_NOT_FOUND: dict[int | str, dict[str, Any]] = {404: {"description": "No such robot, no cell, or the cell ended"}}


@router.put("", response_model=CellPublic, responses=_PRECONDITION)
@operation(Scope.write)
def put_cell(
    robot_id: str,
    *,
    body: CellDocument,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    actor: ActorDep,
    if_match: IfMatch = None,
) -> Response:
    """A new version of the robot's cell (the earlier ones stay readable); the answer's ETag is the robot's."""
    cell, etag = cells.put_cell(
        db=db, models=models, registry=registry, robot_id=robot_id, body=body, actor=actor, if_match=if_match
    )
    return model_json(cell, etag=etag)


@router.get("", response_model=CellPublic, responses=_NOT_FOUND)
@operation(Scope.read)
def get_cell(
    robot_id: str,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    version: int | None = Query(None, ge=1, le=2**31 - 1, description="A past version (default: current)"),
) -> Response:
    """The cell as stored, with what the checks use on the robot now: its shapes (defaults, a URDF's, the
    overrides) and the pairs of solids allowed to touch, each with why."""
    return model_json(cells.get_cell(db=db, models=models, registry=registry, robot_id=robot_id, version=version))


robot_list(
    router,
    "/versions",
    CellVersionPublic,
    cells.cell_versions,
    name="list_cell_versions",
    doc="""Every version of the robot's cell, oldest first, those that ended it included.""",
)


@router.delete("", status_code=204, responses={**_PRECONDITION, **_NOT_FOUND})
@operation(Scope.admin)
def delete_cell(robot_id: str, db: DatabaseDep, actor: ActorDep, if_match: IfMatch = None) -> Response:
    """Ends the cell: designs and checks have none after it; its versions stay readable."""
    etag = cells.delete_cell(db=db, robot_id=robot_id, actor=actor, if_match=if_match)
    return Response(status_code=204, headers={"ETag": etag})


@router.post("/check", response_model=CellCheckPublic)
@operation(Scope.read, runs=Runs.COMPUTE)
async def check_cell(
    robot_id: str,
    *,
    body: CellCheckCreate,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    """Each pose (joints in mm and degrees) feasible or not, with the first reason and what caused it: a
    plant engineer checks a pose list before running it. Joints outside their ranges are refused, not a 422."""
    # Counted after parsing: a body's brackets would count a mesh's triangles as poses.
    cost = limits.cell_check(len(body.poses))
    kwargs = {"db": db, "models": models, "registry": registry, "robot_id": robot_id, "body": body}
    found = await compute.admitted(cost, "cell_check", cells.check_cell, **kwargs)
    return model_json(found)
