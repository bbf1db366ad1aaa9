from __future__ import annotations

from datetime import UTC, datetime

from models.errors import InvalidInput
from service.audit_actions import AuditAction
from service.persistence import Database
from service.persistence.lifecycle import Lifecycle
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


def list_events(
    *,
    db: Database,
    robot_id: str | None,
    action: AuditAction | None,
    since: datetime | None,
    until: datetime | None,
    limit: int,
    offset: int,
) -> list[AuditEventPublic]:
    start, end = _aware(since, "since"), _aware(until, "until")
    if start is not None and end is not None and end <= start:
        raise InvalidInput("until must be after since", field="until")
    with db.reader() as s:
        rows = Lifecycle(s).events(robot_id=robot_id, action=action, since=start, until=end, limit=limit, offset=offset)
        return [event_out(e) for e in rows]
