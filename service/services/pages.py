"""A page of one robot's stored results, as every list of them reads it."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle

Row = TypeVar("Row")
Public = TypeVar("Public")


def robot_page(
    db: Database,
    robot_id: str,
    rows: Callable[[Lifecycle, str, int, int], list[Row]],
    public: Callable[[Row], Public],
    *,
    limit: int,
    offset: int,
) -> list[Public]:
    """`rows` of the robot (a `Lifecycle` method), oldest first, in their public form: a 404 for a robot that
    does not exist, where an empty page would hide a wrong id."""
    with db.reader() as s:
        Repository(s).robot(robot_id)
        return [public(r) for r in rows(Lifecycle(s), robot_id, limit, offset)]
