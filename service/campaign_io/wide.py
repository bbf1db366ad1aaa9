"""A row that carries several points: the motion-capture body's or the reflector nest's markers, each read at
the same joints (a Qualisys or Vicon export as a calibration script writes it: `x1, y1, z1, …, x4, y4, z4`).

The layout is found from the header: coordinate-and-number (`x1`, `x_1`) or name-number-and-coordinate
(`p2_x`, `marker_2_x`). The TCP's point is the file's plain `x, y, z` where it has them (the column map can
send any point's columns there: `x3=x,y3=y,z3=z`), else the lowest-numbered point; its records are the tracker's.
Every other point becomes `reflector` records named after it (`p2` for `x2`, `marker2` for `marker_2_x`), whose
offsets from the TCP the calibration identifies.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.tabular import Row, Table

AXES = ("x", "y", "z")
NUMBERED = re.compile(r"(x|y|z)_?([1-9][0-9]*)")
NAMED = re.compile(r"([a-z][a-z]*?)_?([1-9][0-9]*)_(x|y|z)")
POINTS = 64
"""At most this many points a row (a mocap body has 3 to 10 markers; a nest 3)."""


@dataclass(frozen=True)
class WidePoint:
    """One point of every row: its name for the records and its x, y, z columns."""

    name: str
    number: int
    columns: tuple[str, str, str]


def wide_points(table: Table) -> list[WidePoint]:
    """The points a header numbers, in order (lowest number first; file order between styles); empty where the
    header numbers none. A point missing a coordinate is refused, naming the columns it has."""
    found: dict[tuple[str, int], dict[str, str]] = {}
    for column in table.columns:
        numbered = NUMBERED.fullmatch(column)
        named = NAMED.fullmatch(column) if numbered is None else None
        if numbered is not None:
            key, axis = ("p", int(numbered.group(2))), numbered.group(1)
        elif named is not None:
            key, axis = (named.group(1), int(named.group(2))), named.group(3)
        else:
            continue
        found.setdefault(key, {})[axis] = column
    incomplete = {key: axes for key, axes in found.items() if set(axes) != set(AXES)}
    if incomplete and len(incomplete) < len(found):
        (prefix, number), axes = next(iter(incomplete.items()))
        missing = [a for a in AXES if a not in axes]
        raise CampaignFileError(
            f"point {prefix}{number} of each row has the column(s) {listed(list(axes.values()))} but no "
            f"{listed(missing)}: give each point its x, y and z (or map them: columns=…=x{number})",
            line=1,
        )
    if incomplete:
        return []  # no complete point: not this layout (a lone `x1` column is some other quantity)
    if len(found) > POINTS:
        raise CampaignFileError(f"the header names {len(found)} points a row; at most {POINTS} are read", line=1)
    order = {key: min(table.column_number(c) for c in axes.values()) for key, axes in found.items()}
    keys = sorted(found, key=lambda k: (k[1], order[k]))
    return [WidePoint(f"{k[0]}{k[1]}", k[1], (found[k]["x"], found[k]["y"], found[k]["z"])) for k in keys]


def split_tcp(table: Table, points: Sequence[WidePoint], tcp_found: bool) -> tuple[Table, list[WidePoint]]:
    """The table as the single-point reader reads the TCP (the TCP point's columns renamed x, y, z, the other
    points' columns hidden) and the other points, which become reflector records."""
    others = list(points) if tcp_found else list(points[1:])
    renames = {} if tcp_found else dict(zip(points[0].columns, AXES, strict=True))
    if renames and any(a in table.columns for a in AXES):
        clash = [a for a in AXES if a in table.columns]
        raise CampaignFileError(
            f"the header has column(s) {listed(clash)} beside the numbered points but not all of x, y, z: map the "
            "TCP's point to x, y, z (columns=x1=x,y1=y,z1=z) or rename them",
            line=1,
        )
    hidden = {c for p in others for c in p.columns}
    columns = tuple(renames.get(c, c) for c in table.columns if c not in hidden)
    units = {renames.get(k, k): u for k, u in table.units.items() if k not in hidden}
    rows = (
        tuple(Row(r.line, {renames.get(k, k): v for k, v in r.cells.items()}) for r in table.rows)
        if renames
        else table.rows
    )
    view = Table(columns, units, rows, table.delimiter, table.decimal_comma, table.notes, table.length_unit)
    return view, others


def wide_note(tcp: str, others: Sequence[WidePoint]) -> str:
    return (
        f"{len(others) + 1} points a row: {tcp} read as the TCP's tracker records, "
        f"{listed([p.name for p in others])} as reflector records (their offsets from the TCP identified)"
    )


def reflector_record(joints: list[float], name: str, position: list[float], sigma_mm: float | None) -> dict[str, Any]:
    record: dict[str, Any] = {"kind": "reflector", "reflector": name, "joints": joints, "position": position}
    if sigma_mm is not None:
        record["sigma_mm"] = sigma_mm
    return record
