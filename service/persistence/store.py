"""What every store of records shares: the caller's session, an insert that flushes, a read by id that answers
`NotFound` naming the resource, and a robot's records in the order they were made, a page at a time."""

from __future__ import annotations

from typing import Any, TypeVar

from sqlalchemy import select
from sqlalchemy.orm import Session

from service.errors import NotFound

Row = TypeVar("Row")


def _found(row: Row | None, row_id: str, resource: str) -> Row:
    if row is None:
        raise NotFound(f"no {resource.replace('_', ' ')} with id {row_id!r}", resource=resource, id=row_id)
    return row


class Store:
    def __init__(self, session: Session) -> None:
        self.s = session

    def _insert(self, row: Row) -> Row:
        """Added and flushed, so its defaults (created_at) and any constraint violation show at once."""
        self.s.add(row)
        self.s.flush()
        return row

    def _by_id(self, table: type[Row], row_id: str, resource: str) -> Row:
        return _found(self.s.get(table, row_id), row_id, resource)

    def _selected_by_id(self, table: Any, row_id: str, resource: str, *, lock: bool = False) -> Any:
        """The row by id as a SELECT reads it (FOR UPDATE with `lock`: held until the transaction ends), or
        `NotFound` naming the resource."""
        query = select(table).where(table.id == row_id)
        return _found(self.s.scalars(query.with_for_update() if lock else query).first(), row_id, resource)

    def _of_robot(self, table: Any, robot_id: str, limit: int, offset: int) -> list[Any]:
        """`table`'s rows of the robot, oldest first (the id breaks ties of one timestamp, so pages never
        overlap)."""
        query = (
            select(table)
            .where(table.robot_id == robot_id)
            .order_by(table.created_at, table.id)
            .limit(limit)
            .offset(offset)
        )
        return list(self.s.scalars(query))
