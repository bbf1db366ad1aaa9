"""CSV in (campaigns, read tolerantly by `service.campaign_io`) and out (joint vectors): the `text/csv` codec."""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Sequence

from service.campaign_io import (
    CampaignFileError,
    ImportOptions,
    campaign_records,
    joined_records,
    read_spatial_analyzer,
    read_table,
)
from service.campaign_io.errors import listed
from service.campaign_io.reference_table import is_reference_table, reference_records

CAMPAIGN_HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
JOINT_HEADER = CAMPAIGN_HEADER[:10]
POSE_COLUMNS = ["x", "y", "z", "qw", "qx", "qy", "qz"]
LEGS = ["l1", "l2", "l3", "l4", "l5", "l6"]


def parse_campaign(text: str, *, options: ImportOptions | None = None) -> tuple[list[dict[str, object]], list[str]]:
    """A `text/csv` campaign body as the API's records, read by the tolerant reader (BOM, `;` or tab, decimal
    commas, comments, columns by name in any order, units in the header), and the reader's notes (columns
    ignored, units converted). The header names the robot's joints (robots.md: q1 … q_m, l1 … l6; the robot
    checks their count, a 422 naming its length) and x, y, z [, qw, qx, qy, qz] [, sigma_mm] [, temperature_c]
    (kept on each record: the thermal model term uses it, the score test after a geometric fit reads it)."""
    table = read_table(text, expected=CAMPAIGN_HEADER)
    if is_reference_table(table):  # a `kind` column: distance, point, plane and tracker rows
        return reference_records(table, joint_columns(table.columns), options or ImportOptions())
    return campaign_records(table, joint_columns(table.columns), options or ImportOptions())


def joined_campaign(
    joints: str, points: str, *, spatial_analyzer: bool, options: ImportOptions | None = None
) -> tuple[list[dict[str, object]], list[str]]:
    """The controller's joint file and the instrument's point file (CSV or SpatialAnalyzer's ASCII export),
    joined by pose id, as the API's records and the reader's notes."""
    point_table = read_spatial_analyzer(points) if spatial_analyzer else read_table(points)
    joint_table = read_table(joints)
    return joined_records(joint_table, point_table, joint_columns(joint_table.columns), options or ImportOptions())


JOINT_STYLES = ("q", "a", "j", "axis", "joint")
"""How a header may number the serial joints, 1-based: q1 … (robots.md), A1 … (KUKA), J1 … (ABB, Fanuc), axis1 …
and joint1 … (case does not matter: the reader lowers it). One style a file."""


def joint_columns(columns: Sequence[str]) -> list[str]:
    """The joint columns a header names, in the robot's order: the serial joints 1 … m in one of
    `JOINT_STYLES`, then a hexapod's legs l1 … l6 (a Leica q0…q3 quaternion is not joints: q0 marks it)."""
    if "q0" in columns:
        return JOINT_HEADER  # a Leica-style q0…q3 quaternion: the reader names the clash with the joints
    styles = {
        style: sorted(
            (c for c in columns if re.fullmatch(rf"{style}[1-9][0-9]*", c)), key=lambda c: int(c[len(style) :])
        )
        for style in JOINT_STYLES
    }
    used = [style for style, found in styles.items() if found]
    legs = [leg for leg in LEGS if leg in columns]
    if len(used) > 1:
        raise CampaignFileError(
            f"the header numbers its joints in more than one way ({listed([styles[u][0] for u in used])}): "
            "name them all alike, e.g. q1 … q_m or A1 … A_m",
            line=1,
        )
    if not used and not legs:
        raise CampaignFileError(
            "the header names no joint column: name the robot's joints q1 … q_m in its order (A1 …, J1 …, axis1 … "
            f"and joint1 … are read too; a hexapod's legs are l1 … l6); found: {listed(columns)}",
            line=1,
        )
    style = used[0] if used else "q"
    serial = styles[style]
    expected = [f"{style}{k + 1}" for k in range(len(serial))]
    if serial != expected:
        missing = sorted(set(expected) - set(serial), key=lambda c: int(c[len(style) :]))
        raise CampaignFileError(f"the joint columns skip {listed(missing)}: number them 1 … m in order", line=1)
    return serial + legs


def _numbered(columns: Sequence[str], style: str) -> list[str]:
    """The columns named `<style><k>` (k from 1), by k."""
    found = [c for c in columns if re.fullmatch(rf"{style}[1-9][0-9]*", c)]
    return sorted(found, key=lambda c: int(c[len(style) :]))


def joints_csv(rows: Sequence[Sequence[float | None]], names: Sequence[str]) -> str:
    """Joint vectors under the robot's own joint header (robots.md), never a guessed one."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(list(names))
    for row in rows:
        writer.writerow(["" if v is None else repr(float(v)) for v in row])
    return out.getvalue()
