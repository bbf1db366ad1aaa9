"""Long work as jobs: `submit_job` for every kind, the same use-case functions to run them, and the job's view."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from pydantic import BaseModel

from service.conversions.calibrations import calibration_public
from service.conversions.designs import design_public
from service.conversions.jobs import accepted_out, job_out
from service.model_cache import ModelCache
from service.persistence import Database, Repository
from service.schemas.calibrations import CalibrationCreate
from service.schemas.designs import PoseDesignCreate
from service.schemas.jobs import JobAccepted, JobKind, JobPublic
from service.services import calibrations, designs


class Submitter(Protocol):
    """What runs a queued job: the app's `JobRunner`."""

    def submit(self, job_id: str) -> None: ...


def submit_job(*, db: Database, jobs: Submitter, kind: JobKind, robot_id: str, body: BaseModel) -> JobAccepted:
    """Store the validated request as a queued job of an existing robot and hand it to the runner."""
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)
        job = repo.add_job(kind, robot_id, body.model_dump(mode="json"))
    jobs.submit(job.id)
    return accepted_out(job)


def _calibration(db: Database, models: ModelCache, robot_id: str, request: dict[str, Any]) -> str:
    body = CalibrationCreate.model_validate(request)
    return str(calibrations.calibrate(db=db, robot_id=robot_id, body=body)["id"])


def _design(db: Database, models: ModelCache, robot_id: str, request: dict[str, Any]) -> str:
    body = PoseDesignCreate.model_validate(request)
    return str(designs.create_design(db=db, models=models, robot_id=robot_id, body=body)["id"])


RUNS: dict[str, Callable[[Database, ModelCache, str, dict[str, Any]], str]] = {
    "calibration": _calibration,
    "pose_design": _design,
}
"""Per job kind: the use case that runs it, returning the id of what it created."""


def run_job(*, db: Database, models: ModelCache, kind: str, robot_id: str, request: dict[str, Any]) -> str:
    if kind not in RUNS:
        raise ValueError(f"no such job kind {kind!r}")
    return RUNS[kind](db, models, robot_id, request)


def get_job(*, db: Database, job_id: str) -> JobPublic:
    with db.reader() as s:
        repo = Repository(s)
        job = repo.job(job_id)
        result = None
        if job.status == "succeeded" and job.result_id:
            if job.kind == "calibration":
                result = calibration_public(repo.calibration(job.result_id))
            else:
                result = design_public(repo.design(job.result_id))
        return job_out(job, result)


def queue_depth(*, db: Database) -> dict[str, int]:
    """Jobs waiting and running, for the metrics."""
    with db.reader() as s:
        repo = Repository(s)
        return {status: repo.count_jobs(status) for status in ("queued", "running")}
