"""Reads and writes of the calibration lifecycle: parameter versions made by hand (restore, import, edited guesses),
the audit trail, revisions (ETags), campaigns, validations, checks and the list of pose designs.

Every method works inside the caller's transaction, like `Repository`. A change of a robot or of its current
version always goes through `changed`, which bumps the robot's revision and writes the audit event in the same
transaction: there is no way to change one without the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import func, select

from service.audit_actions import AuditAction
from service.errors import PreconditionFailed
from service.persistence.repository import Repository, new_id
from service.persistence.store import Store
from service.persistence.tables import (
    AuditEvent,
    CampaignRecord,
    CheckRecord,
    ParameterVersion,
    PoseDesignRecord,
    Robot,
    RobotCellRecord,
    ValidationRecord,
)


@dataclass(frozen=True)
class Actor:
    """Who asks: the API key's name (never the key itself; None when the service runs without keys) and the
    request id, so an audit event can be matched with the request's log lines."""

    name: str | None = None
    request_id: str | None = None


@dataclass(frozen=True)
class AuditQuery:
    """Which events of the trail: one robot's (also after its deletion), one action, a time window
    [since, until) in aware datetimes, and a page."""

    robot_id: str | None = None
    action: AuditAction | None = None
    since: datetime | None = None
    until: datetime | None = None
    limit: int = 100
    offset: int = 0


def etag(robot: Robot) -> str:
    return f'"{robot.revision}"'


def check_if_match(if_match: str | None, current: str, what: str) -> None:
    """RFC 9110 If-Match with strong comparison: absent or `*` passes, otherwise one listed tag must be `current`,
    the ETag of `what` (as the refusal names it)."""
    if if_match is None:
        return
    tags = [t.strip() for t in if_match.split(",") if t.strip()]
    if "*" in tags or current in tags:
        return
    raise PreconditionFailed(
        f"If-Match {if_match!r} does not match {what}, now at revision {current}: read it again and retry",
        current=current,
    )


def check_revision(robot: Robot, if_match: str | None) -> None:
    """If-Match against the robot's revision (`check_if_match`)."""
    check_if_match(if_match, etag(robot), f"robot {robot.id!r}")


class Lifecycle(Store):
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
        return self._insert(
            AuditEvent(
                actor=actor.name,
                request_id=actor.request_id,
                # Still a check at run time (a ValueError, a programming error) for callers mypy does not see; the
                # column holds the plain string, as a row read back does.
                action=AuditAction(action).value,
                robot_id=robot.id,
                version=version,
                details=details,
            )
        )

    def events(self, wanted: AuditQuery) -> list[AuditEvent]:
        query = select(AuditEvent)
        if wanted.robot_id is not None:
            query = query.where(AuditEvent.robot_id == wanted.robot_id)
        if wanted.action is not None:
            query = query.where(AuditEvent.action == wanted.action.value)
        if wanted.since is not None:
            query = query.where(AuditEvent.at >= wanted.since)
        if wanted.until is not None:
            query = query.where(AuditEvent.at < wanted.until)
        query = query.order_by(AuditEvent.at, AuditEvent.id).limit(wanted.limit).offset(wanted.offset)
        return list(self.s.scalars(query))

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
        conditions: dict[str, Any] | None = None,
    ) -> int:
        """A new version (never an update of an old one) that becomes current, made by `actor`."""
        version = Repository(self.s).latest_version(robot.id) + 1
        self._insert(
            ParameterVersion(
                robot_id=robot.id,
                version=version,
                values=list(values),
                std_errors=None if std_errors is None else list(std_errors),
                identifiable=None if identifiable is None else list(identifiable),
                provenance=provenance,
                calibration_id=calibration_id,
                actor=actor.name,
                restored_from=restored_from,
                conditions=conditions,
            )
        )
        robot.current_version = version
        self.s.flush()
        return version

    # ---------------------------------------------------------------- the cell
    def add_cell(self, robot: Robot, document: dict[str, Any] | None, actor: Actor) -> RobotCellRecord:
        """A new version of the robot's cell (`document` None: the version that ends it), audited and the robot's
        revision bumped: a cell changes what the robot's designs may choose, so If-Match guards it like the
        robot's own fields."""
        latest = self.s.scalar(select(func.max(RobotCellRecord.version)).where(RobotCellRecord.robot_id == robot.id))
        row = self._insert(
            RobotCellRecord(robot_id=robot.id, version=(latest or 0) + 1, document=document, actor=actor.name)
        )
        action = AuditAction.CELL_UPDATED if document is not None else AuditAction.CELL_ENDED
        self.changed(robot, action, actor, version=robot.current_version, details={"cell_version": row.version})
        return row

    def cell(self, robot_id: str, version: int | None = None) -> RobotCellRecord | None:
        """A version of the robot's cell, the latest without `version` (None: no such version)."""
        query = select(RobotCellRecord).where(RobotCellRecord.robot_id == robot_id)
        if version is not None:
            query = query.where(RobotCellRecord.version == version)
        return self.s.scalars(query.order_by(RobotCellRecord.version.desc()).limit(1)).first()

    def cells(self, robot_id: str, limit: int, offset: int) -> list[RobotCellRecord]:
        query = (
            select(RobotCellRecord)
            .where(RobotCellRecord.robot_id == robot_id)
            .order_by(RobotCellRecord.version)
            .limit(limit)
            .offset(offset)
        )
        return list(self.s.scalars(query))

    # ---------------------------------------------------------------- campaigns, validations, designs
    def campaign(self, campaign_id: str) -> CampaignRecord:
        return self._by_id(CampaignRecord, campaign_id, "campaign")

    def add_validation(
        self,
        robot_id: str,
        campaign_id: str,
        result: dict[str, Any],
        notes: str | None,
        instrument: dict[str, Any] | None,
    ) -> ValidationRecord:
        return self._insert(
            ValidationRecord(
                id=new_id(),
                robot_id=robot_id,
                campaign_id=campaign_id,
                result=result,
                notes=notes,
                instrument=instrument,
            )
        )

    def validation(self, validation_id: str) -> ValidationRecord:
        return self._by_id(ValidationRecord, validation_id, "validation")

    def validations(self, robot_id: str, limit: int = 1000, offset: int = 0) -> list[ValidationRecord]:
        return self._of_robot(ValidationRecord, robot_id, limit, offset)

    def delete_validations(self, robot_id: str) -> None:
        # Before the campaigns they point at (Repository.delete_robot deletes those row by row); the checks too.
        for row in [*self.validations(robot_id, limit=1_000_000_000), *self.checks(robot_id, limit=1_000_000_000)]:
            self.s.delete(row)
        self.s.flush()

    def add_check(
        self, robot_id: str, campaign_id: str, version: int, verdict: str, result: dict[str, Any]
    ) -> CheckRecord:
        return self._insert(
            CheckRecord(
                id=new_id(), robot_id=robot_id, campaign_id=campaign_id, version=version, verdict=verdict, result=result
            )
        )

    def check(self, check_id: str) -> CheckRecord:
        return self._by_id(CheckRecord, check_id, "check")

    def checks(self, robot_id: str, limit: int = 1000, offset: int = 0) -> list[CheckRecord]:
        return self._of_robot(CheckRecord, robot_id, limit, offset)

    def designs(self, robot_id: str, limit: int, offset: int) -> list[PoseDesignRecord]:
        return self._of_robot(PoseDesignRecord, robot_id, limit, offset)
