from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from service.schemas.calibrations import CalibrationPublic
from service.schemas.common import Public, optional
from service.schemas.designs import PoseDesignPublic
from service.schemas.problems import Problem
from service.schemas.programs import ProgramResponse

JobKind = Literal["calibration", "pose_design", "program_compensation"]
JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobAccepted(Public):
    job_id: str
    status_url: str
    id: str | None = optional("The job's id again, as GET /v1/jobs/{id} names it (= job_id)")


class JobProgress(Public):
    stage: str = Field(description="reading, identifying, designing, storing, done, …")
    fraction: float = Field(ge=0, le=1)
    iteration: int | None = Field(
        default=None, exclude_if=lambda v: v is None, description="The solver's iteration within the stage"
    )
    eta_seconds: float | None = Field(
        default=None,
        exclude_if=lambda v: v is None,
        description="The stage's time left if its solve takes as many iterations as this robot's solves have "
        "taken in this worker (absent before the first)",
    )


class JobPublic(Public):
    id: str
    kind: JobKind
    status: JobStatus
    robot_id: str
    progress: JobProgress | None = Field(description="The latest progress point its worker reported")
    worker: str | None = Field(description="host:pid of the worker that holds (or last held) it")
    attempts: int = Field(description="Times a worker took it (more than 1 after a worker stopped mid-way)")
    cancel_requested: bool
    # A program compensation's result is the answer its synchronous request would have given (stored as is).
    result: CalibrationPublic | PoseDesignPublic | ProgramResponse | None = Field(
        description="When succeeded: what it created"
    )
    error: Problem | None = Field(description="When failed: what the synchronous request would have answered")
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
