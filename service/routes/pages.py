"""A robot's stored results of one kind, a page at a time (calibrations, validations, checks, pose designs,
adaptive campaigns, cell versions): every such list reads the same, so one function declares them."""

from __future__ import annotations

from typing import Any, Protocol

from fastapi import APIRouter, Response
from pydantic import BaseModel

from service.http.deps import DatabaseDep, Limit, Offset
from service.http.operations import operation
from service.http.responses import models_json
from service.http.security import Scope
from service.persistence.database import Database


class RobotRows(Protocol):
    """A service function that reads a page of one robot's stored results, oldest first (404 for no robot)."""

    def __call__(self, *, db: Database, robot_id: str, limit: int, offset: int) -> list[Any]: ...


def robot_list(
    router: APIRouter, path: str, item: type[BaseModel], rows: RobotRows, *, name: str, doc: str | None = None
) -> None:
    """Declare `GET path` on `router`: a page of the robot's `rows` (`?limit=`, default 100, and `?offset=`) as a
    JSON array of `item`. `name` is the operation's (its operationId and summary), `doc` its description."""

    @operation(Scope.read)
    def endpoint(robot_id: str, db: DatabaseDep, limit: Limit = 100, offset: Offset = 0) -> Response:
        return models_json(rows(db=db, robot_id=robot_id, limit=limit, offset=offset), item)

    endpoint.__name__ = endpoint.__qualname__ = name
    endpoint.__doc__ = doc
    router.add_api_route(path, endpoint, methods=["GET"], response_model=list[item], name=name)  # type: ignore[valid-type]
