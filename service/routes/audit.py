from __future__ import annotations

from datetime import datetime

from fastapi import APIRouter, Query, Response

from service.http.deps import DatabaseDep, Limit, Offset
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import models_json
from service.http.security import Scope
from service.persistence.lifecycle import AuditQuery
from service.schemas.audit import Action, AuditEventPublic
from service.services import audit

router = APIRouter(tags=["audit"], route_class=OffloopRoute)


@router.get("/v1/audit", response_model=list[AuditEventPublic])
@operation(Scope.read)
def list_audit(
    db: DatabaseDep,
    *,
    robot_id: str | None = Query(None, max_length=36, description="One robot's events (also after its deletion)"),
    action: Action | None = Query(None),
    since: datetime | None = Query(None, description="From this time on (inclusive), RFC 3339"),
    until: datetime | None = Query(None, description="Before this time (exclusive), RFC 3339"),
    limit: Limit = 100,
    offset: Offset = 0,
) -> Response:
    """Oldest first: robots created, changed and deleted, and every change of a robot's current version."""
    wanted = AuditQuery(robot_id=robot_id, action=action, since=since, until=until, limit=limit, offset=offset)
    events = audit.list_events(db=db, query=wanted)
    return models_json(events, AuditEventPublic)
