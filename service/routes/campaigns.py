from __future__ import annotations

import csv
import io
from collections.abc import Sequence
from typing import Any

from fastapi import APIRouter, Query, Request, Response

from service.csv_codec import CAMPAIGN_HEADER, POSE_COLUMNS
from service.deps import DatabaseDep, ModelCacheDep, negotiate
from service.json_bodies import OffloopRoute
from service.operations import operation
from service.responses import model_json
from service.schemas.campaigns import CampaignPublic, CampaignRecordPublic
from service.schemas.references import (
    DistanceRecordPublic,
    ImageRecordPublic,
    PlaneRecordPublic,
    PointRecordPublic,
)
from service.security import Scope
from service.services import campaigns

router = APIRouter(tags=["campaigns"], route_class=OffloopRoute)
_FORMATS = {"json": "application/json", "csv": "text/csv"}
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
    numbers exactly as stored; a campaign with distance, point or plane records in the layout of several kinds
    (`service.campaign_io.reference_table`)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    tracker = [r for r in campaign.measurements if isinstance(r, CampaignRecordPublic)]
    if len(tracker) < len(campaign.measurements):
        writer.writerow([*KIND_COLUMNS[:2], *joint_names, *KIND_COLUMNS[2:]])
        for r in campaign.measurements:
            writer.writerows(_kind_rows(r))
        return out.getvalue()
    with_orientation = any(r.orientation is not None for r in tracker)
    # A record's own σ and temperature (a tracker file's U(95) / 2, its Temperature column) go back out with it,
    # so the CSV fitted again is the same campaign.
    extra = [c for c in ("sigma_mm", "temperature_c") if any(getattr(r, c) is not None for r in tracker)]
    writer.writerow([*joint_names, *(POSE_COLUMNS if with_orientation else POSE_COLUMNS[:3]), *extra])
    for r in tracker:
        cells = [repr(float(v)) for v in (*r.joints, *r.position)]
        if with_orientation:
            cells += [repr(float(v)) for v in r.orientation] if r.orientation is not None else ["", "", "", ""]
        cells += ["" if (v := getattr(r, c)) is None else repr(float(v)) for c in extra]
        writer.writerow(cells)
    return out.getvalue()


KIND_COLUMNS = ("kind", "reference", "distance_mm", "x", "y", "z", "u", "v", "sigma_mm", "sigma_px")
"""The layout of several kinds (`service.campaign_io.reference_table`) around the joints: an image is a row per
point it saw, x y z the point and u v its pixel."""


def _kind_rows(
    r: CampaignRecordPublic | DistanceRecordPublic | PointRecordPublic | PlaneRecordPublic | ImageRecordPublic,
) -> list[list[str]]:
    joints = [repr(float(v)) for v in r.joints]
    if isinstance(r, CampaignRecordPublic):
        return [["tracker", "", *joints, "", *(repr(float(v)) for v in r.position), "", "", "", ""]]
    if isinstance(r, ImageRecordPublic):
        sigma_px = "" if r.sigma_px is None else repr(float(r.sigma_px))
        return [
            ["image", r.camera, *joints, "", *(repr(float(v)) for v in (*p.target_mm, *p.pixel)), "", sigma_px]
            for p in r.points
        ]
    sigma = "" if r.sigma_mm is None else repr(float(r.sigma_mm))
    if isinstance(r, DistanceRecordPublic):
        return [["distance", r.anchor, *joints, repr(float(r.distance_mm)), "", "", "", "", "", sigma, ""]]
    name = r.point if isinstance(r, PointRecordPublic) else r.plane
    return [[r.kind, name, *joints, "", "", "", "", "", "", sigma, ""]]


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
    media = _FORMATS[format] if format else negotiate(request, list(_FORMATS.values()))
    campaign = campaigns.get_campaign(db=db, campaign_id=campaign_id)
    if media == "text/csv":
        names = models.current(campaign.robot_id)[0].joint_names
        return Response(campaign_csv(campaign, names), media_type="text/csv")
    return model_json(campaign)
