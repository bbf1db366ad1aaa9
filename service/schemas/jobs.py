from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from service.schemas.calibrations import CalibrationPublic
from service.schemas.common import Public
from service.schemas.designs import PoseDesignPublic
from service.schemas.problems import Problem

JobKind = Literal["calibration", "pose_design"]
JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobAccepted(Public):
    job_id: str
    status_url: str


class JobPublic(Public):
    id: str
    kind: JobKind
    status: JobStatus
    result: CalibrationPublic | PoseDesignPublic | None = Field(description="When succeeded: what it created")
    error: Problem | None = Field(description="When failed: what the synchronous request would have answered")
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
