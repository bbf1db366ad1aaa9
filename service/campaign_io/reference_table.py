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
from service.campaign_io.records import ImportOptions, joint_rows, joint_unit_notes, length_factor
from service.campaign_io.tabular import Row, Table

KIND_COLUMN = "kind"
REFERENCE_COLUMNS = ("reference", "anchor", "plane", "feature", "camera")
DISTANCE_COLUMNS = ("distance_mm", "distance", "length")
SIGMA_COLUMNS = ("sigma_mm", "sigma", "uncertainty")
NAMED_BY = {"distance": "anchor", "point": "point", "plane": "plane", "image": "camera"}
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
    out: list[dict[str, Any]] = []
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
        if kind == "image":
            _seen(table, row, q, name, out=out, options=options)
            continue
        rec: dict[str, Any] = {"kind": kind, "joints": q, NAMED_BY[kind]: name}
        if kind == "distance":
            if distance is None:
                raise CampaignFileError(f"line {row.line}: a distance record needs a distance_mm column", line=1)
            rec["distance_mm"] = table.number(row, distance) * scale
        if sigma and row.cells.get(sigma, "").strip():
            rec["sigma_mm"] = table.number(row, sigma) * length_factor(table, sigma, options)
        out.append(rec)
    for rec in out:
        rec.pop("_image", None)  # the grouping key only
    return out, notes


def _seen(
    table: Table, row: Row, joints: list[float], camera: str, *, out: list[dict[str, Any]], options: ImportOptions
) -> None:
    """An image row is one point a camera saw (x, y, z the point, u, v its pixel): consecutive rows of one camera
    at the same joints (and the same `image` id, where the file has the column) are one image."""
    missing = [c for c in ("x", "y", "z", "u", "v") if c not in table.columns]
    if missing:
        raise CampaignFileError(
            f"line {row.line}: an image row needs the columns x, y, z (the point) and u, v (its pixel); missing: "
            f"{listed(missing)}",
            line=row.line,
        )
    scale = length_factor(table, "x", options)
    point = {
        "target_mm": [table.number(row, c) * scale for c in ("x", "y", "z")],
        "pixel": [table.number(row, c) for c in ("u", "v")],
    }
    image_id = row.cells.get("image", "").strip()
    last = out[-1] if out else None
    if (
        last is not None
        and last.get("kind") == "image"
        and last["camera"] == camera
        and last["joints"] == joints
        and last.get("_image", "") == image_id
    ):
        last["points"].append(point)
        return
    rec: dict[str, Any] = {"kind": "image", "joints": joints, "camera": camera, "points": [point], "_image": image_id}
    if "sigma_px" in table.columns and row.cells.get("sigma_px", "").strip():
        rec["sigma_px"] = table.number(row, "sigma_px")
    out.append(rec)


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
