"""The CSV layout of a campaign of several kinds (a ballbar, a socket, a touch probe, tracker positions), one
record a row, its kind in a `kind` column:

    kind,reference,q1,…,q6,distance_mm,x,y,z,sigma_mm
    distance,a1,…,150.0012,,,,
    point,p1,…,,,,,
    plane,f1,…,,,,,0.005
    tracker,,…,,812.1,-40.2,633.0,

`reference` (or `anchor`, `plane`, `feature`) names the anchor, point or plane; a `distance` may carry its unit
in the header (`distance [in]`) like the positions do; a `tracker` row (or an empty kind) is a tracker
position. Joints are read as for a tracker campaign (robots.md's names or a controller's A1 / J1 / axis1).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.records import ImportOptions, joint_rows, joint_unit_notes, length_factor
from service.campaign_io.tabular import Row, Table

KIND_COLUMN = "kind"
REFERENCE_COLUMNS = ("reference", "anchor", "plane", "feature")
DISTANCE_COLUMNS = ("distance_mm", "distance", "length")
SIGMA_COLUMNS = ("sigma_mm", "sigma", "uncertainty")
NAMED_BY = {"distance": "anchor", "point": "point", "plane": "plane"}
"""A record kind → the field that names its reference in the API's record."""
TRACKER_KINDS = ("", "tracker", "position")


def is_reference_table(table: Table) -> bool:
    """A table in this layout: it has a `kind` column."""
    return KIND_COLUMN in table.columns


def reference_records(
    table: Table, joint_names: Sequence[str], options: ImportOptions
) -> tuple[list[dict[str, Any]], list[str]]:
    """The API's records of each row (distance, point, plane or tracker), and the reader's notes."""
    reference = _first(table, REFERENCE_COLUMNS)
    distance = _first(table, DISTANCE_COLUMNS)
    sigma = _first(table, SIGMA_COLUMNS)
    joints = joint_rows(table, joint_names)
    notes = [*table.notes, *joint_unit_notes(table, joint_names)]
    scale = length_factor(table, distance, options) if distance else 1.0
    if distance and scale != 1.0:
        notes.append(f"distances converted to mm (×{scale:g})")
    out = []
    for (_, _, q), row in zip(joints, table.rows, strict=True):
        kind = row.cells.get(KIND_COLUMN, "").strip().lower()
        if kind in TRACKER_KINDS:
            out.append(_tracker(table, row, q, options))
            continue
        if kind not in NAMED_BY:
            raise CampaignFileError(
                f"line {row.line}: kind {kind!r} is none of distance, point, plane, tracker",
                line=row.line,
                column=table.column_number(KIND_COLUMN),
            )
        name = row.cells.get(reference, "").strip() if reference else ""
        if not name:
            raise CampaignFileError(
                f"line {row.line}: a {kind} record names its {NAMED_BY[kind]} in a column {listed(REFERENCE_COLUMNS)}",
                line=row.line,
            )
        rec: dict[str, Any] = {"kind": kind, "joints": q, NAMED_BY[kind]: name}
        if kind == "distance":
            if distance is None:
                raise CampaignFileError(f"line {row.line}: a distance record needs a distance_mm column", line=1)
            rec["distance_mm"] = table.number(row, distance) * scale
        if sigma and row.cells.get(sigma, "").strip():
            rec["sigma_mm"] = table.number(row, sigma) * length_factor(table, sigma, options)
        out.append(rec)
    return out, notes


def anchor_names(records: Sequence[dict[str, Any]]) -> list[str]:
    """The anchors the records name, in order of first appearance."""
    return list(dict.fromkeys(str(r["anchor"]) for r in records if r.get("kind") == "distance"))


def _tracker(table: Table, row: Row, joints: list[float], options: ImportOptions) -> dict[str, Any]:
    missing = [c for c in ("x", "y", "z") if c not in table.columns]
    if missing:
        raise CampaignFileError(
            f"line {row.line}: a tracker record needs the columns x, y, z (missing: {listed(missing)})", line=row.line
        )
    scale = length_factor(table, "x", options)
    rec: dict[str, Any] = {"joints": joints, "position": [table.number(row, c) * scale for c in ("x", "y", "z")]}
    sigma = _first(table, SIGMA_COLUMNS)
    if sigma and row.cells.get(sigma, "").strip():
        rec["sigma_mm"] = table.number(row, sigma) * length_factor(table, sigma, options)
    return rec


def _first(table: Table, names: Sequence[str]) -> str | None:
    return next((n for n in names if n in table.columns), None)
