"""The audit trail: who changed which robot or current parameter version, when, in which request."""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING

from pydantic import Field

from service.audit_actions import AuditAction
from service.schemas.common import Public, absent_if_none, values_of

if TYPE_CHECKING:
    Action = AuditAction
else:
    Action = values_of(AuditAction)


class AuditDetailsPublic(Public):
    """What the action needs to be understood; the keys that do not apply are absent."""

    changed: list[str] | None = absent_if_none("Fields a PATCH changed")
    name: str | None = absent_if_none("The robot's name at the time")
    from_version: int | None = absent_if_none("Current version before the change")
    calibration_id: str | None = absent_if_none()
    restored_from: int | None = absent_if_none()
    forced: bool | None = absent_if_none("A calibration applied although a check failed")
    cell_version: int | None = absent_if_none("The cell version a cell change made")


class AuditEventPublic(Public):
    id: int
    at: datetime
    actor: str | None = Field(description="Name of the API key (never the key); null without keys")
    request_id: str | None
    action: Action
    robot_id: str | None
    version: int | None = Field(description="The robot's current version after the change")
    details: AuditDetailsPublic
