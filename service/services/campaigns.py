from __future__ import annotations

from service.persistence import Database
from service.persistence.lifecycle import Lifecycle
from service.schemas.campaigns import CampaignPublic


def get_campaign(*, db: Database, campaign_id: str) -> CampaignPublic:
    with db.reader() as s:
        row = Lifecycle(s).campaign(campaign_id)
        return CampaignPublic.model_validate(
            {
                "id": row.id,
                "robot_id": row.robot_id,
                "created_at": row.created_at,
                "measurements": [
                    {"joints": r["joints"], "position": r["position"], "orientation": r.get("orientation")}
                    for r in row.records
                ],
            }
        )
