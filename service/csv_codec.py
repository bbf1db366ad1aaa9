"""CSV in (campaigns, read tolerantly by `service.campaign_io`) and out (joint vectors): the `text/csv` codec."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence

from service.campaign_io import ImportOptions, campaign_records, joined_records, read_spatial_analyzer, read_table

CAMPAIGN_HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
JOINT_HEADER = CAMPAIGN_HEADER[:10]


def parse_campaign(text: str, *, options: ImportOptions | None = None) -> tuple[list[dict[str, object]], list[str]]:
    """A `text/csv` campaign body as the API's records, read by the tolerant reader (BOM, `;` or tab, decimal
    commas, comments, columns by name in any order, units in the header), and the reader's notes (columns
    ignored, units converted). The header names the robot's joints and x, y, z [, qw, qx, qy, qz] [, sigma_mm]."""
    table = read_table(text, expected=CAMPAIGN_HEADER)
    records, notes = campaign_records(table, JOINT_HEADER, options or ImportOptions())
    if any("temperature_c" in r for r in records):
        notes.append("the temperature column was read but not used: no thermal model term is on")
    return [{k: v for k, v in r.items() if k != "temperature_c"} for r in records], notes


def joined_campaign(
    joints: str, points: str, *, spatial_analyzer: bool, options: ImportOptions | None = None
) -> tuple[list[dict[str, object]], list[str]]:
    """The controller's joint file and the instrument's point file (CSV or SpatialAnalyzer's ASCII export),
    joined by pose id, as the API's records and the reader's notes."""
    point_table = read_spatial_analyzer(points) if spatial_analyzer else read_table(points)
    records, notes = joined_records(read_table(joints), point_table, JOINT_HEADER, options or ImportOptions())
    return [{k: v for k, v in r.items() if k != "temperature_c"} for r in records], notes


def joints_csv(rows: Sequence[Sequence[float | None]]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(JOINT_HEADER)
    for row in rows:
        writer.writerow(["" if v is None else repr(float(v)) for v in row])
    return out.getvalue()
