from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import ConfigDict, Field

from service.schemas.calibrations import CalibrationPublic
from service.schemas.common import Public
from service.schemas.designs import PoseDesignPublic

JobKind = Literal["calibration", "pose_design"]
JobStatus = Literal["queued", "running", "succeeded", "failed", "cancelled"]


class JobAccepted(Public):
    job_id: str
    status_url: str


class ProblemPublic(Public):
    """An RFC 9457 problem document, as the synchronous request would have answered.

    Its extension members (which pose, which joint, which limit) depend on the error's type: RFC 9457 leaves
    them open, so this is the one response object that allows more keys."""

    model_config = ConfigDict(extra="allow")
    type: str = Field(default="about:blank", description="RFC 9457's default when a problem names no type")
    title: str
    status: int
    detail: str


class JobPublic(Public):
    id: str
    kind: JobKind
    status: JobStatus
    result: CalibrationPublic | PoseDesignPublic | None = Field(description="When succeeded: what it created")
    error: ProblemPublic | None = Field(description="When failed")
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
