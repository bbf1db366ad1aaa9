"""Jobs: the row, with what it created, as `JobPublic`."""

from __future__ import annotations

from service.persistence.tables import Job
from service.schemas.calibrations import CalibrationPublic
from service.schemas.designs import PoseDesignPublic
from service.schemas.jobs import JobAccepted, JobPublic
from service.schemas.programs import ProgramResponse


def accepted_out(job: Job) -> JobAccepted:
    return JobAccepted(job_id=job.id, status_url=f"/v1/jobs/{job.id}", id=job.id)


def job_out(job: Job, result: CalibrationPublic | PoseDesignPublic | ProgramResponse | None) -> JobPublic:
    return JobPublic.model_validate(
        {
            "id": job.id,
            "kind": job.kind,
            "status": job.status,
            "robot_id": job.robot_id,
            "progress": job.progress,
            "worker": job.worker,
            "attempts": job.attempts,
            "cancel_requested": job.cancel_requested,
            "result": result,
            "error": job.error,
            "created_at": job.created_at,
            "started_at": job.started_at,
            "finished_at": job.finished_at,
        }
    )
