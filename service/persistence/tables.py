"""The stored records. Parameter versions are immutable; a robot points at its current one."""

from __future__ import annotations

import hashlib
import json
from datetime import UTC, datetime
from typing import Any, ClassVar

from sqlalchemy import (
    JSON,
    DateTime,
    Dialect,
    ForeignKey,
    Integer,
    LargeBinary,
    String,
    Text,
    TypeDecorator,
    UniqueConstraint,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column


def fleet_key_of(structure: dict[str, Any] | None) -> str:
    """A digest of a structure document without its base and tool guesses (the IWR's, `None`: of "iwr"): robots
    with the same key are one model, a fleet. Migration 0008 holds a frozen copy of this for the rows it fills."""
    document: object = "iwr" if structure is None else {k: v for k, v in structure.items() if k not in ("base", "tool")}
    canonical = json.dumps(document, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(canonical.encode()).hexdigest()[:16]


def now() -> datetime:
    return datetime.now(UTC)


class UTCDateTime(TypeDecorator[datetime]):
    """Timestamps always come back timezone-aware (SQLite stores them without the zone)."""

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_result_value(self, value: datetime | None, dialect: Dialect) -> datetime | None:
        if value is not None and value.tzinfo is None:
            return value.replace(tzinfo=UTC)
        return value


class Base(DeclarativeBase):
    type_annotation_map: ClassVar[dict[Any, Any]] = {dict[str, Any]: JSON, list[Any]: JSON}


class Robot(Base):
    __tablename__ = "robots"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    model: Mapped[str] = mapped_column(String(20))
    base: Mapped[list[Any]] = mapped_column(JSON)
    """Nominal base guess: x, y, z (mm), rotation vector (rad)."""
    tool: Mapped[list[Any]] = mapped_column(JSON)
    current_version: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    notes: Mapped[str | None] = mapped_column(Text, nullable=True)
    revision: Mapped[int] = mapped_column(Integer, default=1)
    """Bumped by every change of the robot or of its current version: the robot's ETag."""
    structure: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    """The description document (shared/spec/robots.md) of a custom robot; None for the built-in IWR."""
    urdf: Mapped[str | None] = mapped_column(Text, nullable=True)
    """The URDF a robot was imported from, as sent (or built from UR's kinematics file): its calibrated export
    is this document with only the chain's joint origins changed. None for a robot of another origin."""
    base_link: Mapped[str | None] = mapped_column(String(200), nullable=True)
    tip_link: Mapped[str | None] = mapped_column(String(200), nullable=True)
    fleet_key: Mapped[str] = mapped_column(String(16), index=True)
    """The robot's fleet, `fleet_key_of(structure)`: stored so that a fleet is read by one indexed query, not by
    digesting every robot's document (migration 0008 filled it for the robots before it)."""


class ParameterVersion(Base):
    __tablename__ = "parameter_versions"
    __table_args__ = (UniqueConstraint("robot_id", "version"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    version: Mapped[int] = mapped_column(Integer)
    values: Mapped[list[Any]] = mapped_column(JSON)
    """All parameters, internal units (mm, rad)."""
    std_errors: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)
    identifiable: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)
    provenance: Mapped[str] = mapped_column(String(20))
    calibration_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    actor: Mapped[str | None] = mapped_column(String(100), nullable=True)
    """Name of the API key that made this version (never the key); null without keys."""
    restored_from: Mapped[int | None] = mapped_column(Integer, nullable=True)
    conditions: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    """What the campaign that made it was measured under (`ConditionsPublic`, boundary units); null: no campaign."""


class CampaignRecord(Base):
    __tablename__ = "campaigns"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    records: Mapped[list[Any]] = mapped_column(JSON)
    """The measurements exactly as received (boundary units), kept for audit."""
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class CampaignOutcome:
    """The columns of what an operation made of a stored campaign (a calibration, a validation, a quick check):
    its robot and campaign, its result document, the notes and the instrument it was sent with."""

    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    campaign_id: Mapped[str] = mapped_column(ForeignKey("campaigns.id", ondelete="CASCADE"))
    result: Mapped[dict[str, Any]] = mapped_column(JSON)
    notes: Mapped[str | None] = mapped_column(Text, nullable=True)
    instrument: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    """{"name", "serial"} of the instrument that measured the campaign."""
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class CalibrationRecord(CampaignOutcome, Base):
    __tablename__ = "calibrations"
    status: Mapped[str] = mapped_column(String(20))
    applied: Mapped[bool] = mapped_column(default=False)
    parameter_version: Mapped[int | None] = mapped_column(Integer, nullable=True)
    start_version: Mapped[int | None] = mapped_column(Integer, nullable=True)
    """The parameter version the fit started from (null for calibrations stored before it was recorded)."""


class ValidationRecord(CampaignOutcome, Base):
    __tablename__ = "validations"


class CheckRecord(CampaignOutcome, Base):
    """A quick check (models.evaluation.checks): a few records against the version current then, and its verdict."""

    __tablename__ = "checks"
    version: Mapped[int] = mapped_column(Integer)
    verdict: Mapped[str] = mapped_column(String(20))


class AuditEvent(Base):
    """One change of a robot or of its current parameter version; kept after the robot is deleted."""

    __tablename__ = "audit_events"
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now, index=True)
    actor: Mapped[str | None] = mapped_column(String(100), nullable=True)
    request_id: Mapped[str | None] = mapped_column(String(64), nullable=True)
    action: Mapped[str] = mapped_column(String(40))
    robot_id: Mapped[str | None] = mapped_column(String(36), nullable=True, index=True)
    version: Mapped[int | None] = mapped_column(Integer, nullable=True)
    details: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)


class IdempotencyRecord(Base):
    """The first answer to a POST carrying an Idempotency-Key (per API key), replayed to its retries."""

    __tablename__ = "idempotency_keys"
    actor: Mapped[str] = mapped_column(String(100), primary_key=True)
    key: Mapped[str] = mapped_column(String(200), primary_key=True)
    method: Mapped[str] = mapped_column(String(10))
    path: Mapped[str] = mapped_column(String(500))
    body_sha256: Mapped[str] = mapped_column(String(64))
    status: Mapped[int | None] = mapped_column(Integer, nullable=True)
    """Null while the first request is still being answered."""
    content_type: Mapped[str | None] = mapped_column(String(100), nullable=True)
    body: Mapped[bytes | None] = mapped_column(LargeBinary, nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    expires_at: Mapped[datetime] = mapped_column(UTCDateTime(), index=True)


class PoseDesignRecord(Base):
    __tablename__ = "pose_designs"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    result: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class RobotCellRecord(Base):
    """One version of a robot's cell (`CellDocument` as sent, boundary units); a version whose document is null
    ended the cell (DELETE). Versions are never changed: each PUT and each DELETE adds one."""

    __tablename__ = "robot_cells"
    __table_args__ = (UniqueConstraint("robot_id", "version"),)
    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    version: Mapped[int] = mapped_column(Integer)
    document: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    actor: Mapped[str | None] = mapped_column(String(100), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class CompensatedProgramRecord(Base):
    """What a program compensation run as a job answered (`ProgramResponse`), for its job's result: the request
    is the job's own."""

    __tablename__ = "compensated_programs"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    result: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class AdaptiveCampaignRecord(Base):
    """An adaptive campaign (optimal_design.adaptive): what was asked, the candidate pool it chooses from (drawn
    once, so a restart resumes on the same pool), and its state after the last step."""

    __tablename__ = "adaptive_campaigns"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    robot_id: Mapped[str] = mapped_column(ForeignKey("robots.id", ondelete="CASCADE"), index=True)
    version: Mapped[int] = mapped_column(Integer)
    """The robot's version the campaign started from (its values are the first estimate)."""
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    pool: Mapped[dict[str, Any]] = mapped_column(JSON)
    """The candidates (internal units), the first batch's indices, the reachable error, the refusals."""
    state: Mapped[dict[str, Any]] = mapped_column(JSON)
    """Status, the estimate, the excluded records, the poses asked for and the next ones, why it ended."""
    steps: Mapped[int] = mapped_column(Integer, default=0)
    calibration_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    updated_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class AdaptiveStepRecord(Base):
    """One post of records to an adaptive campaign and what it answered; (campaign, number) is unique, so two
    posts racing for one step cannot both be stored."""

    __tablename__ = "adaptive_steps"
    __table_args__ = (UniqueConstraint("campaign_id", "number", name="uq_adaptive_steps_campaign_number"),)
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    campaign_id: Mapped[str] = mapped_column(ForeignKey("adaptive_campaigns.id", ondelete="CASCADE"), index=True)
    number: Mapped[int] = mapped_column(Integer)
    records: Mapped[list[Any]] = mapped_column(JSON)
    """The records posted (as the request gave them: mm, degrees)."""
    result: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)


class RobotTreeRecord(Base):
    """A robot of several chains (`RobotTreeCreate`): its tree document as built (branches in order, boundary
    units; a URDF's as read from it, the URDF kept beside) and its current parameters (internal units, null:
    nominal), which an applied calibration replaces, bumping the revision (the ETag)."""

    __tablename__ = "robot_trees"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    document: Mapped[dict[str, Any]] = mapped_column(JSON)
    source: Mapped[str] = mapped_column(String(20))
    urdf: Mapped[str | None] = mapped_column(Text, nullable=True)
    base_link: Mapped[str | None] = mapped_column(String(200), nullable=True)
    tip_links: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)
    revision: Mapped[int] = mapped_column(Integer, default=1)
    parameters: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)
    std_errors: Mapped[list[Any] | None] = mapped_column(JSON, nullable=True)
    calibration_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    actor: Mapped[str | None] = mapped_column(String(100), nullable=True)


class RobotTreeCalibrationRecord(Base):
    """A tree calibration: its records as received (boundary units, with the request's noise and, as `start`, the
    fit's start parameters in internal units: its report restates the fit from them) and its answer
    (`TreeCalibrationPublic`)."""

    __tablename__ = "robot_tree_calibrations"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    tree_id: Mapped[str] = mapped_column(ForeignKey("robot_trees.id", ondelete="CASCADE"), index=True)
    applied: Mapped[bool] = mapped_column(default=False)
    revision: Mapped[int | None] = mapped_column(Integer, nullable=True)
    start_revision: Mapped[int] = mapped_column(Integer)
    records: Mapped[dict[str, Any]] = mapped_column(JSON)
    result: Mapped[dict[str, Any]] = mapped_column(JSON)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    actor: Mapped[str | None] = mapped_column(String(100), nullable=True)


class Job(Base):
    __tablename__ = "jobs"
    id: Mapped[str] = mapped_column(String(36), primary_key=True)
    kind: Mapped[str] = mapped_column(String(30))
    robot_id: Mapped[str] = mapped_column(String(36), index=True)
    request: Mapped[dict[str, Any]] = mapped_column(JSON)
    status: Mapped[str] = mapped_column(String(20), index=True)
    result_id: Mapped[str | None] = mapped_column(String(36), nullable=True)
    error: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=now)
    started_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    finished_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    note: Mapped[str | None] = mapped_column(Text, nullable=True)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    worker: Mapped[str | None] = mapped_column(String(200), nullable=True)
    """The worker holding the lease (host:pid:…) while running."""
    lease_expires_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True, index=True)
    progress: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    cancel_requested: Mapped[bool] = mapped_column(default=False)
