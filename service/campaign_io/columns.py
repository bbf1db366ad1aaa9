"""Which file column is which joint or coordinate: the robot's own joint names and the user's column map.

A campaign file names its joints as the tools that wrote it do: `q1` (robots.md), `A1` (KUKA), `J1` (ABB,
Fanuc), or the names of the robot's URDF (`joint_1` in ROS-Industrial's, `panda_joint1`, a UR's
`shoulder_pan_joint`). The robot knows its URDF's names (the moving joints from base_link to tip_link, in
order), so a header that uses them is read without a map; anything else a map says: `J1=joint_1,X_m=x`, each
file column to a joint (the robot's `q<k>` or its URDF name) or to a coordinate (x, y, z, qw …, pose_id,
sigma_mm, u95, temperature_c, time, reference, reflector).
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.tabular import Row, Table, normalise

COORDINATES = (
    "x",
    "y",
    "z",
    "qw",
    "qx",
    "qy",
    "qz",
    "pose_id",
    "sigma_mm",
    "u95",
    "temperature_c",
    "timestamp",
    "reference",
    "reflector",
)
"""What a map may send a file column to, beside the robot's joints (`time` is accepted for `timestamp`)."""
MAP_ENTRIES = 200


@dataclass(frozen=True)
class RobotColumns:
    """The robot's joints as a file may name them: `q1 … q_m` (robots.md's, the API's), and per joint the other
    names it answers to (its URDF's), and which joints turn (a `joint_unit` option converts only those)."""

    names: tuple[str, ...]
    aliases: Mapping[str, str] = field(default_factory=dict)
    """Another name (normalised) → the robot's joint name."""
    revolute: frozenset[str] = frozenset()

    def joint(self, name: str) -> str | None:
        key = normalise(name)
        if key in self.names:
            return key
        return self.aliases.get(key)


def parse_column_map(text: str | None) -> tuple[tuple[str, str], ...]:
    """`"J1=joint_1, X [m]=x"` → (("j1", "joint_1"), ("x", "x")): file column (normalised as the reader does) →
    its meaning. A unit in the file column's name stays the file's: the map only says what the column is."""
    if text is None or not text.strip():
        return ()
    out: list[tuple[str, str]] = []
    for entry in (e for e in text.split(",") if e.strip()):
        column, sep, meaning = entry.partition("=")
        if not sep or not column.strip() or not meaning.strip():
            raise CampaignFileError(
                f"column map entry {entry.strip()!r}: write FILE_COLUMN=JOINT_OR_COORDINATE, e.g. J1=joint_1 or "
                "X_m=x, entries separated by commas"
            )
        out.append((normalise(column), meaning.strip()))
    if len(out) > MAP_ENTRIES:
        raise CampaignFileError(f"the column map has {len(out)} entries; at most {MAP_ENTRIES}")
    sources = [c for c, _ in out]
    twice = sorted({c for c in sources if sources.count(c) > 1})
    if twice:
        raise CampaignFileError(f"the column map names the file column(s) {listed(twice)} twice")
    return tuple(out)


POINT_COORDINATE = re.compile(r"[xyz][1-9][0-9]*")
"""A map may name a point of a row that carries several (`x2`: point 2's x; `service.campaign_io.wide`)."""


def _meaning(meaning: str, robot: RobotColumns | None) -> str:
    key = normalise(meaning)
    key = "timestamp" if key == "time" else key
    if key in COORDINATES or POINT_COORDINATE.fullmatch(key):
        return key
    joint = robot.joint(meaning) if robot is not None else (key if key.startswith("q") and key[1:].isdigit() else None)
    if joint is None:
        names = list(robot.names) + sorted(set(robot.aliases)) if robot is not None else ["q1 … q_m"]
        raise CampaignFileError(
            f"the column map sends a column to {meaning!r}, which is neither a joint of this robot ({listed(names)}) "
            f"nor a coordinate ({', '.join(COORDINATES)}, or x2, y2, z2 … for a row's further points)"
        )
    return joint


def mapped(
    table: Table, column_map: Sequence[tuple[str, str]], robot: RobotColumns | None, *, required: bool = True
) -> tuple[Table, list[str]]:
    """`table` with its columns renamed: the map's first, then the robot's URDF names; and a note of what was
    renamed. With `required`, a mapped column the table lacks is an error (a map for two files checks each
    entry against both: `required=False` per file, `missing_columns` over both)."""
    renames: dict[str, str] = {}
    for column, meaning in column_map:
        if column in table.columns:
            renames[column] = _meaning(meaning, robot)
        elif required:
            raise CampaignFileError(
                f"the column map names the file column {column!r}, which the header lacks (found: "
                f"{listed(table.columns)})",
                line=1,
            )
    if robot is not None:
        for column in table.columns:
            joint = robot.aliases.get(column)
            if column not in renames and joint is not None and joint not in table.columns:
                renames[column] = joint
    if not renames:
        return table, []
    targets = list(renames.values())
    clashes = sorted(
        {t for t in targets if targets.count(t) > 1} | {t for t in targets if t in table.columns and t not in renames}
    )
    if clashes:
        raise CampaignFileError(
            f"after the column map, {listed(clashes)} would be two columns: map one file column to each", line=1
        )
    columns = tuple(renames.get(c, c) for c in table.columns)
    rows = tuple(Row(r.line, {renames.get(k, k): v for k, v in r.cells.items()}) for r in table.rows)
    units = {renames.get(k, k): u for k, u in table.units.items()}
    shown = [f"{c} → {renames[c]}" for c in table.columns if c in renames]
    note = f"columns read as: {listed(shown)}"
    return (
        Table(columns, units, rows, table.delimiter, table.decimal_comma, table.notes, table.length_unit),
        [note],
    )


def missing_columns(column_map: Sequence[tuple[str, str]], *tables: Table) -> None:
    """A map entry whose column is in none of the files: named, with what the files have."""
    present = {c for t in tables for c in t.columns}
    absent = [c for c, _ in column_map if c not in present]
    if absent:
        raise CampaignFileError(
            f"the column map names the file column(s) {listed(absent)}, which no file has (found: "
            f"{listed(sorted(present))})",
            line=1,
        )


def with_joint_unit(table: Table, joints: Sequence[str], unit: str | None) -> Table:
    """`table` with `unit` (the request's `joint_unit`) on the joint columns whose header states none."""
    if unit is None:
        return table
    units = dict(table.units)
    for name in joints:
        units.setdefault(name, unit)
    return Table(table.columns, units, table.rows, table.delimiter, table.decimal_comma, table.notes, table.length_unit)


def with_length_unit(table: Table, prismatic: Sequence[str], unit: str) -> Table:
    """`table` with `unit` on the prismatic joint columns whose header states none: a file states one length
    unit (the request's `length_unit`, or its preamble's), for its points and its sliding joints alike (a TIAGo's
    torso in metres beside its markers in metres). mm, the API's unit, changes nothing."""
    if unit.lower() == "mm":
        return table
    units = dict(table.units)
    for name in prismatic:
        units.setdefault(name, unit.lower())
    return Table(table.columns, units, table.rows, table.delimiter, table.decimal_comma, table.notes, table.length_unit)
