"""A stored campaign: the measurements exactly as they were received."""

from __future__ import annotations

from datetime import datetime

from pydantic import Field

from service.schemas.common import Public
from service.schemas.references import (
    DistanceRecordPublic,
    ImageRecordPublic,
    PlaneRecordPublic,
    PointRecordPublic,
)


class CampaignRecordPublic(Public):
    joints: list[float] = Field(description="[q1 (mm), q2 (mm), q3 (deg), q4 (deg), l1 … l6 (mm)]")
    position: list[float] = Field(description="mm")
    orientation: list[float] | None = Field(description="unit quaternion [w, x, y, z]; null when not measured")
    sigma_mm: float | None = Field(
        default=None, description="The record's own position σ (mm; a file's U(95) / 2); null: the campaign's noise"
    )
    temperature_c: float | None = Field(default=None, description="The record's temperature (°C); null: none given")


class CampaignPublic(Public):
    id: str
    robot_id: str
    created_at: datetime
    measurements: list[
        CampaignRecordPublic | DistanceRecordPublic | PointRecordPublic | PlaneRecordPublic | ImageRecordPublic
    ] = Field(description="As received: a tracker's records (no kind), or a distance, point or plane record")
