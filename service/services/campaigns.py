from __future__ import annotations

from typing import Any

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
                "measurements": [_record(r) for r in row.records],
            }
        )


REFERENCE_FIELDS = {
    "distance": ("anchor", "distance_mm", "sigma_mm"),
    "point": ("point", "sigma_mm"),
    "plane": ("plane", "sigma_mm"),
    "image": ("camera", "points", "sigma_px"),
}
"""What a stored record of each kind shows beside its joints and σ (a tracker's: position and orientation)."""


def _record(stored: dict[str, Any]) -> dict[str, Any]:
    kind = stored.get("kind")
    if kind is None:
        return {
            "joints": stored["joints"],
            "position": stored["position"],
            "orientation": stored.get("orientation"),
            "sigma_mm": stored.get("sigma_mm"),
            "temperature_c": stored.get("temperature_c"),
        }
    shown = ("kind", "joints", *REFERENCE_FIELDS[kind])
    return {key: stored.get(key) for key in shown}
