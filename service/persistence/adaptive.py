"""Adaptive campaigns and their steps; every method works inside the caller's transaction."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from service.errors import Conflict, NotFound
from service.persistence.repository import new_id
from service.persistence.store import Store
from service.persistence.tables import AdaptiveCampaignRecord, AdaptiveStepRecord, now


class AdaptiveStore(Store):
    def add(
        self, robot_id: str, version: int, request: dict[str, Any], pool: dict[str, Any], state: dict[str, Any]
    ) -> AdaptiveCampaignRecord:
        row = AdaptiveCampaignRecord(
            id=new_id(), robot_id=robot_id, version=version, request=request, pool=pool, state=state, steps=0
        )
        return self._insert(row)

    def campaign(self, robot_id: str, campaign_id: str, *, lock: bool = False) -> AdaptiveCampaignRecord:
        """The robot's campaign (NotFound for another robot's: its id says nothing of this robot)."""
        query = select(AdaptiveCampaignRecord).where(AdaptiveCampaignRecord.id == campaign_id)
        found = self.s.scalars(query.with_for_update() if lock else query).first()
        if found is None or found.robot_id != robot_id:
            raise NotFound(
                f"robot {robot_id!r} has no adaptive campaign with id {campaign_id!r}",
                resource="adaptive_campaign",
                id=campaign_id,
            )
        return found

    def campaigns(self, robot_id: str, limit: int, offset: int) -> list[AdaptiveCampaignRecord]:
        return self._of_robot(AdaptiveCampaignRecord, robot_id, limit, offset)

    def steps(self, campaign_id: str) -> list[AdaptiveStepRecord]:
        query = select(AdaptiveStepRecord).where(AdaptiveStepRecord.campaign_id == campaign_id)
        return list(self.s.scalars(query.order_by(AdaptiveStepRecord.number)))

    def add_step(
        self, campaign: AdaptiveCampaignRecord, expected: int, records: list[Any], result: dict[str, Any]
    ) -> AdaptiveStepRecord:
        """Step `expected + 1`, if the campaign is still at `expected` steps (a 409 when another post won)."""
        if campaign.steps != expected:
            raise Conflict(
                f"adaptive campaign {campaign.id} moved on while these records were processed (step {campaign.steps}, "
                f"not {expected}): read it again and post what it asks next",
                id=campaign.id,
            )
        number = expected + 1
        row = AdaptiveStepRecord(id=new_id(), campaign_id=campaign.id, number=number, records=records, result=result)
        campaign.steps = number
        campaign.updated_at = now()
        return self._insert(row)
