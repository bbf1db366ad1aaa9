"""A stored campaign: the measurements exactly as they were received."""

from __future__ import annotations

from datetime import datetime

from pydantic import Field

from service.record_kinds import PublicRecord
from service.schemas.common import Public


class CampaignPublic(Public):
    id: str
    robot_id: str
    created_at: datetime
    measurements: list[PublicRecord] = Field(
        description="As received: a tracker's records (no kind), or a distance, point or plane record"
    )
