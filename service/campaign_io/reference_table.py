"""The CSV layout of a campaign of several kinds (a ballbar, a socket, a touch probe, tracker positions), one
record a row, its kind in a `kind` column:

    kind,reference,q1,…,q6,distance_mm,x,y,z,u,v,sigma_mm,sigma_px
    distance,a1,…,150.0012,,,,,,,
    point,p1,…,,,,,,,,
    plane,f1,…,,,,,,,0.005,
    tracker,,…,,812.1,-40.2,633.0,,,,
    image,c1,…,,25.0,-25.0,0.0,1023.41,611.87,,0.1

`reference` (or `anchor`, `plane`, `feature`, `camera`) names the anchor, point, plane or camera; a `distance`
may carry its unit in the header (`distance [in]`) like the positions do; a `tracker` row (or an empty kind)
is a tracker position; an `image` row is one point a camera saw (x, y, z the point in the frame it is given
in, u, v its pixel), consecutive rows of one camera at the same joints forming one image (an `image` column,
where present, separates two images taken at the same joints). A camera's intrinsics are not in the file: a
multipart upload carries them beside it. Joints are read as for a tracker campaign (robots.md's names or a
controller's A1 / J1 / axis1).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.records import ImportOptions, joint_rows, joint_unit_notes
from service.campaign_io.tabular import Table
from service.record_kinds import (
    BY_FILE_KIND,
    DISTANCE,
    KIND_COLUMN,
    RECORD_KINDS,
    REFERENCE_COLUMNS,
    FileRow,
    file_kinds_listed,
    kind_of,
)


def is_reference_table(table: Table) -> bool:
    """A table in this layout: it has a `kind` column."""
    return KIND_COLUMN in table.columns


def reference_records(
    table: Table, joint_names: Sequence[str], options: ImportOptions
) -> tuple[list[dict[str, Any]], list[str]]:
    """The API's records of each row (each its kind's, `service.record_kinds`), and the reader's notes."""
    reference = next((n for n in REFERENCE_COLUMNS if n in table.columns), None)
    joints = joint_rows(table, joint_names)
    notes = [*table.notes, *joint_unit_notes(table, joint_names)]
    for each in RECORD_KINDS.values():
        notes += each.table_notes(table, options)
    out: list[dict[str, Any]] = []
    for (_, _, q), row in zip(joints, table.rows, strict=True):
        value = row.cells.get(KIND_COLUMN, "").strip().lower()
        kind = BY_FILE_KIND.get(value)
        if kind is None:
            raise CampaignFileError(
                f"line {row.line}: kind {value!r} is none of {file_kinds_listed()}",
                line=row.line,
                column=table.column_number(KIND_COLUMN),
            )
        name = row.cells.get(reference, "").strip() if reference else ""
        if kind.named_by is not None and not name:
            raise CampaignFileError(
                f"line {row.line}: a {value} record names its {kind.named_by} in a column {listed(REFERENCE_COLUMNS)}",
                line=row.line,
            )
        kind.read_row(FileRow(table, row, q, name, options), out)
    for rec in out:
        kind_of(rec).finish(rec)
    return out, notes


def anchor_names(records: Sequence[dict[str, Any]]) -> list[str]:
    """The anchors the records name, in order of first appearance."""
    return list(dict.fromkeys(DISTANCE.reference_name(r) for r in records if kind_of(r) is DISTANCE))
