"""Reads and writes of the calibration lifecycle: parameter versions made by hand (restore, import, edited guesses),
the audit trail, revisions (ETags), campaigns, validations and the list of pose designs.

Every method works inside the caller's transaction, like `Repository`. A change of a robot or of its current
version always goes through `changed`, which bumps the robot's revision and writes the audit event in the same
transaction: there is no way to change one without the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from service.audit_actions import AuditAction
from service.errors import NotFound, PreconditionFailed
from service.persistence.repository import Repository, new_id
from service.persistence.tables import (
    AuditEvent,
    CampaignRecord,
    ParameterVersion,
    PoseDesignRecord,
    Robot,
    ValidationRecord,
)


@dataclass(frozen=True)
class Actor:
    """Who asks: the API key's name (never the key itself; None when the service runs without keys) and the
    request id, so an audit event can be matched with the request's log lines."""

    name: str | None = None
    request_id: str | None = None


def etag(robot: Robot) -> str:
    return f'"{robot.revision}"'


def check_revision(robot: Robot, if_match: str | None) -> None:
    """RFC 9110 If-Match with strong comparison: absent or `*` passes, otherwise one listed tag must be current."""
    if if_match is None:
        return
    tags = [t.strip() for t in if_match.split(",") if t.strip()]
    if "*" in tags or etag(robot) in tags:
        return
    raise PreconditionFailed(
        f"If-Match {if_match!r} does not match robot {robot.id!r}, now at revision {etag(robot)}: "
        "read it again and retry",
        current=etag(robot),
    )


class Lifecycle:
    def __init__(self, session: Session) -> None:
        self.s = session

    # ---------------------------------------------------------------- changes and the trail
    def changed(
        self,
        robot: Robot,
        action: AuditAction,
        actor: Actor,
        *,
        version: int | None = None,
        details: dict[str, Any] | None = None,
        bump: bool = True,
    ) -> AuditEvent:
        if bump:
            robot.revision = (robot.revision or 1) + 1
        event = AuditEvent(
            actor=actor.name,
            request_id=actor.request_id,
            # Still a check at run time (a ValueError, a programming error) for callers mypy does not see; the
            # column holds the plain string, as a row read back does.
            action=AuditAction(action).value,
            robot_id=robot.id,
            version=version,
            details=details,
        )
        self.s.add(event)
        self.s.flush()
        return event

    def events(
        self,
        *,
        robot_id: str | None,
        action: AuditAction | None,
        since: datetime | None,
        until: datetime | None,
        limit: int,
        offset: int,
    ) -> list[AuditEvent]:
        query = select(AuditEvent)
        if robot_id is not None:
            query = query.where(AuditEvent.robot_id == robot_id)
        if action is not None:
            query = query.where(AuditEvent.action == action.value)
        if since is not None:
            query = query.where(AuditEvent.at >= since)
        if until is not None:
            query = query.where(AuditEvent.at < until)
        return list(self.s.scalars(query.order_by(AuditEvent.at, AuditEvent.id).limit(limit).offset(offset)))

    # ---------------------------------------------------------------- versions
    def versions(self, robot_id: str) -> list[ParameterVersion]:
        query = select(ParameterVersion).where(ParameterVersion.robot_id == robot_id).order_by(ParameterVersion.version)
        return list(self.s.scalars(query))

    def add_version(
        self,
        robot: Robot,
        *,
        values: list[float],
        std_errors: list[Any] | None,
        identifiable: list[Any] | None,
        provenance: str,
        actor: Actor,
        restored_from: int | None = None,
        calibration_id: str | None = None,
    ) -> int:
        """A new version (never an update of an old one) that becomes current, made by `actor`."""
        return Repository(self.s).add_version(
            robot,
            values,
            std_errors,
            identifiable,
            calibration_id,
            provenance=provenance,
            actor=actor.name,
            restored_from=restored_from,
        )

    # ---------------------------------------------------------------- campaigns, validations, designs
    def campaign(self, campaign_id: str) -> CampaignRecord:
        found = self.s.get(CampaignRecord, campaign_id)
        if found is None:
            raise NotFound(f"no campaign with id {campaign_id!r}", resource="campaign", id=campaign_id)
        return found

    def add_validation(
        self,
        robot_id: str,
        campaign_id: str,
        result: dict[str, Any],
        notes: str | None,
        instrument: dict[str, Any] | None,
    ) -> ValidationRecord:
        record = ValidationRecord(
            id=new_id(), robot_id=robot_id, campaign_id=campaign_id, result=result, notes=notes, instrument=instrument
        )
        self.s.add(record)
        self.s.flush()
        return record

    def validation(self, validation_id: str) -> ValidationRecord:
        found = self.s.get(ValidationRecord, validation_id)
        if found is None:
            raise NotFound(f"no validation with id {validation_id!r}", resource="validation", id=validation_id)
        return found

    def validations(self, robot_id: str, limit: int = 1000, offset: int = 0) -> list[ValidationRecord]:
        query = (
            select(ValidationRecord)
            .where(ValidationRecord.robot_id == robot_id)
            .order_by(ValidationRecord.created_at, ValidationRecord.id)
            .limit(limit)
            .offset(offset)
        )
        return list(self.s.scalars(query))

    def delete_validations(self, robot_id: str) -> None:
        # Before the campaigns they point at (Repository.delete_robot deletes those row by row).
        for row in self.validations(robot_id, limit=1_000_000_000):
            self.s.delete(row)
        self.s.flush()

    def designs(self, robot_id: str, limit: int, offset: int) -> list[PoseDesignRecord]:
        query = (
            select(PoseDesignRecord)
            .where(PoseDesignRecord.robot_id == robot_id)
            .order_by(PoseDesignRecord.created_at, PoseDesignRecord.id)
            .limit(limit)
            .offset(offset)
        )
        return list(self.s.scalars(query))
