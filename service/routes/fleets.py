from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Path, Response

from service.http.deps import DatabaseDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import model_json
from service.http.security import Scope
from service.schemas.fleets import FLEET_KEY, FleetPublic
from service.services import fleets

router = APIRouter(tags=["fleets"], route_class=OffloopRoute)
FleetKey = Annotated[str, Path(pattern=FLEET_KEY, description="A fleet's key (`fleet` of a robot's fleet)")]


@router.get("/v1/robots/{robot_id}/fleet", response_model=FleetPublic)
@operation(Scope.read)
def robot_fleet(robot_id: str, db: DatabaseDep) -> Response:
    """The robot's fleet: every robot of its structure document, the population of their calibrated values per
    parameter (mean deviation from nominal and spread, mm / deg), and the units that are not like the others
    (docs/fleet.md)."""
    return model_json(fleets.get_fleet(db=db, robot_id=robot_id))


@router.get("/v1/fleets/{fleet}", response_model=FleetPublic)
@operation(Scope.read)
def fleet(fleet: FleetKey, db: DatabaseDep) -> Response:
    """A fleet by its key (404 when no robot belongs to it)."""
    return model_json(fleets.get_fleet_by_key(db=db, key=fleet))
