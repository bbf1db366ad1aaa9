from __future__ import annotations

from typing import Any

from service.persistence import Database
from service.persistence.lifecycle import Lifecycle
from service.record_kinds import kind_of
from service.schemas.campaigns import CampaignPublic


def get_campaign(*, db: Database, campaign_id: str) -> CampaignPublic:
    with db.reader() as s:
        row = Lifecycle(s).campaign(campaign_id)
        return CampaignPublic.model_validate(
            {
                "id": row.id,
                "robot_id": row.robot_id,
                "created_at": row.created_at,
                "measurements": [_record(r) for r in row.records],
            }
        )


def _record(stored: dict[str, Any]) -> dict[str, Any]:
    """A stored record in its public form: its kind's public fields (`service.record_kinds`)."""
    return kind_of(stored).public_of(stored)
