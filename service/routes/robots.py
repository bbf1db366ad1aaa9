from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, Query, Response

from service import operations
from service.persistence import Database, Repository
from service.routes.deps import database
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPublic

router = APIRouter(prefix="/v1/robots", tags=["robots"])


@router.post("", status_code=201, response_model=RobotPublic)
def create_robot(body: RobotCreate, db: Database = Depends(database)) -> dict[str, Any]:
    return operations.robot_public(operations.create_robot(db, body))


@router.get("", response_model=list[RobotPublic])
def list_robots(
    limit: int = Query(100, ge=1, le=1000),
    offset: int = Query(0, ge=0, le=1_000_000_000),
    db: Database = Depends(database),
) -> list[dict[str, Any]]:
    with db.reader() as s:
        return [operations.robot_public(r) for r in Repository(s).robots(limit, offset)]


@router.get("/{robot_id}", response_model=RobotPublic)
def get_robot(robot_id: str, db: Database = Depends(database)) -> dict[str, Any]:
    with db.reader() as s:
        return operations.robot_public(Repository(s).robot(robot_id))


@router.delete("/{robot_id}", status_code=204)
def delete_robot(robot_id: str, db: Database = Depends(database)) -> Response:
    with db.session() as s:
        Repository(s).delete_robot(robot_id)
    return Response(status_code=204)


@router.get("/{robot_id}/parameters", response_model=ParametersPublic)
def get_parameters(
    robot_id: str,
    version: int | None = Query(None, ge=1, description="A past version (default: current)"),
    db: Database = Depends(database),
) -> dict[str, Any]:
    with db.reader() as s:
        repo = Repository(s)
        desc = operations.description(repo.robot(robot_id))
        return operations.parameters_public(desc, repo.version(robot_id, version))
