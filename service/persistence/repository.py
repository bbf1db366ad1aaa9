"""Reads and writes of the stored records; every method works inside the caller's transaction."""

from __future__ import annotations

import uuid
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import delete, func, select

from models.formats.urdf import UrdfSource
from service.errors import NotFound
from service.persistence.store import Store
from service.persistence.tables import (
    AdaptiveCampaignRecord,
    AdaptiveStepRecord,
    CalibrationRecord,
    CampaignRecord,
    CompensatedProgramRecord,
    Job,
    ParameterVersion,
    PoseDesignRecord,
    Robot,
    RobotCellRecord,
    fleet_key_of,
)


def new_id() -> str:
    return str(uuid.uuid4())


class Repository(Store):
    # ---------------------------------------------------------------- robots
    def add_robot(
        self,
        name: str,
        model: str,
        base: list[float],
        tool: list[float],
        nominal: list[float],
        *,
        structure: dict[str, Any] | None = None,
        urdf: UrdfSource | None = None,
    ) -> Robot:
        robot = self._insert(
            Robot(
                id=new_id(),
                name=name,
                model=model,
                base=base,
                tool=tool,
                current_version=1,
                structure=structure,
                fleet_key=fleet_key_of(structure),
            )
        )
        if urdf is not None:
            robot.urdf, robot.base_link, robot.tip_link = urdf.urdf, urdf.base_link, urdf.tip_link
        self._insert(ParameterVersion(robot_id=robot.id, version=1, values=nominal, provenance="nominal"))
        return robot

    def robot(self, robot_id: str, *, lock: bool = False) -> Robot:
        robot: Robot = self._selected_by_id(Robot, robot_id, "robot", lock=lock)
        return robot

    def robot_named(self, name: str) -> Robot | None:
        return self.s.scalars(select(Robot).where(Robot.name == name).limit(1)).first()

    def current_version(self, robot_id: str) -> int:
        found = self.s.scalar(select(Robot.current_version).where(Robot.id == robot_id))
        if found is None:
            raise NotFound(f"no robot with id {robot_id!r}", resource="robot", id=robot_id)
        return int(found)

    def robots(self, limit: int, offset: int) -> list[Robot]:
        return list(self.s.scalars(select(Robot).order_by(Robot.created_at, Robot.id).limit(limit).offset(offset)))

    def current_versions(self, fleet_key: str) -> list[tuple[Robot, ParameterVersion]]:
        """The robots of one fleet (`Robot.fleet_key`) with their current parameter versions, oldest robot first,
        in one indexed query."""
        query = (
            select(Robot, ParameterVersion)
            .join(
                ParameterVersion,
                (ParameterVersion.robot_id == Robot.id) & (ParameterVersion.version == Robot.current_version),
            )
            .where(Robot.fleet_key == fleet_key)
            .order_by(Robot.created_at, Robot.id)
        )
        return [(row[0], row[1]) for row in self.s.execute(query)]

    def calibrations_with_prior(self, ids: list[str]) -> dict[str, bool]:
        """Of these calibrations, by id, whether each used its fleet's prior (its report's `fleet.prior_used`),
        read from the stored documents without loading them."""
        if not ids:
            return {}
        used = CalibrationRecord.result["fleet"]["prior_used"].as_boolean()
        query = select(CalibrationRecord.id, used).where(CalibrationRecord.id.in_(ids))
        return {row[0]: bool(row[1]) for row in self.s.execute(query)}

    def delete_robot(self, robot_id: str) -> None:
        robot = self.robot(robot_id)
        adaptive = select(AdaptiveCampaignRecord.id).where(AdaptiveCampaignRecord.robot_id == robot_id)
        self.s.execute(delete(AdaptiveStepRecord).where(AdaptiveStepRecord.campaign_id.in_(adaptive)))
        self.s.execute(delete(AdaptiveCampaignRecord).where(AdaptiveCampaignRecord.robot_id == robot_id))
        tables = (
            CalibrationRecord,
            CampaignRecord,
            PoseDesignRecord,
            CompensatedProgramRecord,
            RobotCellRecord,
            ParameterVersion,
        )
        for table in tables:
            for row in self.s.scalars(select(table).where(table.robot_id == robot_id)):
                self.s.delete(row)
        self.s.delete(robot)

    # ---------------------------------------------------------------- parameter versions
    def version(self, robot_id: str, version: int | None = None) -> ParameterVersion:
        robot = self.robot(robot_id)
        wanted = robot.current_version if version is None else version
        found = self.s.scalars(
            select(ParameterVersion).where(ParameterVersion.robot_id == robot_id, ParameterVersion.version == wanted)
        ).first()
        if found is None:
            raise NotFound(f"robot {robot_id!r} has no parameter version {wanted}", resource="parameter_version")
        return found

    def latest_version(self, robot_id: str) -> int:
        latest = self.s.scalar(select(func.max(ParameterVersion.version)).where(ParameterVersion.robot_id == robot_id))
        if latest is None:
            raise NotFound(f"no robot with id {robot_id!r}", resource="robot", id=robot_id)
        return int(latest)

    # ---------------------------------------------------------------- campaigns and calibrations
    def add_campaign(self, robot_id: str, records: list[dict[str, Any]]) -> CampaignRecord:
        return self._insert(CampaignRecord(id=new_id(), robot_id=robot_id, records=records))

    def add_calibration(
        self, calibration_id: str, robot_id: str, campaign_id: str, status: str, result: dict[str, Any]
    ) -> CalibrationRecord:
        return self._insert(
            CalibrationRecord(
                id=calibration_id, robot_id=robot_id, campaign_id=campaign_id, status=status, result=result
            )
        )

    def calibration(self, calibration_id: str) -> CalibrationRecord:
        return self._by_id(CalibrationRecord, calibration_id, "calibration")

    def calibrations(self, robot_id: str, limit: int, offset: int) -> list[CalibrationRecord]:
        self.robot(robot_id)
        return self._of_robot(CalibrationRecord, robot_id, limit, offset)

    # ---------------------------------------------------------------- designs
    def add_design(self, robot_id: str, request: dict[str, Any], result: dict[str, Any]) -> PoseDesignRecord:
        return self._insert(PoseDesignRecord(id=new_id(), robot_id=robot_id, request=request, result=result))

    def design(self, design_id: str) -> PoseDesignRecord:
        return self._by_id(PoseDesignRecord, design_id, "pose_design")

    # ---------------------------------------------------------------- compensated programs (job results)
    def add_compensated_program(self, robot_id: str, result: dict[str, Any]) -> CompensatedProgramRecord:
        return self._insert(CompensatedProgramRecord(id=new_id(), robot_id=robot_id, result=result))

    def compensated_program(self, record_id: str) -> CompensatedProgramRecord:
        return self._by_id(CompensatedProgramRecord, record_id, "compensated_program")

    # ---------------------------------------------------------------- jobs
    def add_job(self, kind: str, robot_id: str, request: dict[str, Any]) -> Job:
        return self._insert(Job(id=new_id(), kind=kind, robot_id=robot_id, request=request, status="queued"))

    def job(self, job_id: str) -> Job:
        return self._by_id(Job, job_id, "job")

    def jobs_with_status(self, status: str) -> list[Job]:
        return list(self.s.scalars(select(Job).where(Job.status == status).order_by(Job.created_at)))

    def count_jobs(self, status: str) -> int:
        return int(self.s.scalar(select(func.count()).select_from(Job).where(Job.status == status)) or 0)

    def start_job(self, job: Job) -> None:
        job.status, job.started_at = "running", datetime.now(UTC)

    def finish_job(self, job: Job, *, result_id: str | None = None, error: dict[str, Any] | None = None) -> None:
        job.status = "failed" if error is not None else "succeeded"
        job.result_id, job.error, job.finished_at = result_id, error, datetime.now(UTC)
