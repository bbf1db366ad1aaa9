from __future__ import annotations

from dataclasses import replace
from datetime import UTC, datetime

from models.errors import InvalidInput
from service.persistence import Database
from service.persistence.lifecycle import AuditQuery, Lifecycle
from service.persistence.tables import AuditEvent
from service.schemas.audit import AuditEventPublic


def _aware(value: datetime | None, field: str) -> datetime | None:
    # A time without a zone is ambiguous in an audit query: ask for one rather than guess the server's.
    if value is not None and value.tzinfo is None:
        raise InvalidInput(
            f"{field}: give a time zone (e.g. 2026-12-01T17:00:00Z), not {value.isoformat()}", field=field
        )
    return None if value is None else value.astimezone(UTC)


def event_out(event: AuditEvent) -> AuditEventPublic:
    return AuditEventPublic.model_validate(
        {
            "id": event.id,
            "at": event.at,
            "actor": event.actor,
            "request_id": event.request_id,
            "action": event.action,
            "robot_id": event.robot_id,
            "version": event.version,
            "details": event.details or {},
        }
    )


def list_events(*, db: Database, query: AuditQuery) -> list[AuditEventPublic]:
    start, end = _aware(query.since, "since"), _aware(query.until, "until")
    if start is not None and end is not None and end <= start:
        raise InvalidInput("until must be after since", field="until")
    with db.reader() as s:
        return [event_out(e) for e in Lifecycle(s).events(replace(query, since=start, until=end))]
