from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from typing import Any

from fastapi import APIRouter, Query, Request, Response

from service.files.csv_codec import CAMPAIGN_HEADER
from service.http.deps import JSON_OR_CSV, DatabaseDep, ModelCacheDep, requested_media
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import model_json
from service.http.security import Scope
from service.record_kinds import FILE_COLUMNS, kind_of, sole_kind
from service.schemas.campaigns import CampaignPublic
from service.services import campaigns

router = APIRouter(tags=["campaigns"], route_class=OffloopRoute)
_CSV: dict[int | str, dict[str, Any]] = {
    200: {
        "content": {
            "text/csv": {
                "schema": {
                    "type": "string",
                    "description": "header: the robot's joint names, then x,y,z[,qw,qx,qy,qz]; the IWR's: "
                    + ",".join(CAMPAIGN_HEADER),
                }
            }
        }
    },
    406: {"description": "Accept allows neither JSON nor CSV"},
}


def campaign_csv(campaign: CampaignPublic, joint_names: Sequence[str]) -> str:
    """The spec's campaign CSV (what POST …/calibrations accepts) under the robot's joint header (robots.md),
    numbers exactly as stored: a campaign of one kind in its own layout where it has one
    (`RecordKind.write_alone`, a tracker's), any other in the layout of several kinds
    (`service.campaign_io.reference_table`)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    alone = sole_kind(campaign.measurements)
    rows = None if alone is None else alone.write_alone(campaign.measurements, joint_names)
    if rows is not None:  # a campaign of one kind with a layout of its own (a tracker's)
        writer.writerows(rows)
        return out.getvalue()
    writer.writerow([*FILE_COLUMNS[:2], *joint_names, *FILE_COLUMNS[2:]])
    for r in campaign.measurements:
        joints = [repr(float(v)) for v in r.joints]
        for row in kind_of(r).file_rows(r):  # an image: a row per point it saw
            writer.writerow([*(row.get(c, "") for c in FILE_COLUMNS[:2]), *joints, *_cells(row)])
    return out.getvalue()


def _cells(cells: dict[str, str]) -> list[str]:
    """A kind's cells after the joints, in the layout's order (empty where the kind has none)."""
    return [cells.get(c, "") for c in FILE_COLUMNS[2:]]


@router.get("/v1/campaigns/{campaign_id}", response_model=CampaignPublic, responses=_CSV)
@operation(Scope.read)
def get_campaign(
    campaign_id: str,
    request: Request,
    db: DatabaseDep,
    models: ModelCacheDep,
    format: str | None = Query(None, pattern="^(json|csv)$", description="Overrides Accept"),
) -> Response:
    """The measurements behind a calibration or validation, as received: JSON, or the spec's CSV."""
    media = requested_media(request, format, JSON_OR_CSV)
    campaign = campaigns.get_campaign(db=db, campaign_id=campaign_id)
    if media == "text/csv":
        names = models.current(campaign.robot_id)[0].joint_names
        return Response(campaign_csv(campaign, names), media_type="text/csv")
    return model_json(campaign)
