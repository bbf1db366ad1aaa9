from __future__ import annotations

from fastapi import APIRouter, Query, Response
from pydantic import TypeAdapter

from service.deps import DatabaseDep
from service.responses import model_json, models_json
from service.schemas.robots import MAX_VERSION, ParametersPublic, RobotCreate, RobotPublic
from service.services import robots

router = APIRouter(prefix="/v1/robots", tags=["robots"])
_ROBOTS = TypeAdapter(list[RobotPublic])


@router.post("", status_code=201, response_model=RobotPublic)
def create_robot(body: RobotCreate, db: DatabaseDep) -> Response:
    return model_json(robots.create_robot(db=db, body=body), status_code=201)


@router.get("", response_model=list[RobotPublic])
def list_robots(
    db: DatabaseDep,
    limit: int = Query(100, ge=1, le=1000),
    offset: int = Query(0, ge=0, le=1_000_000_000),
) -> Response:
    return models_json(robots.list_robots(db=db, limit=limit, offset=offset), _ROBOTS)


@router.get("/{robot_id}", response_model=RobotPublic)
def get_robot(robot_id: str, db: DatabaseDep) -> Response:
    return model_json(robots.get_robot(db=db, robot_id=robot_id))


@router.delete("/{robot_id}", status_code=204)
def delete_robot(robot_id: str, db: DatabaseDep) -> Response:
    robots.delete_robot(db=db, robot_id=robot_id)
    return Response(status_code=204)


@router.get("/{robot_id}/parameters", response_model=ParametersPublic)
def get_parameters(
    robot_id: str,
    db: DatabaseDep,
    version: int | None = Query(None, ge=1, le=MAX_VERSION, description="A past version (default: current)"),
) -> Response:
    return model_json(robots.get_parameters(db=db, robot_id=robot_id, version=version))
