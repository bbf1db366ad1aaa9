"""Tables → the API's measurement records: columns by name, units and conventions as the file states them.

A campaign arrives as one table (joints and measurements per row) or as two that the user's tools wrote
separately: the controller's joint file and the instrument's point file, joined by a pose id. Lengths become mm
(from the header's unit, else the chosen `length_unit`), quaternions `[w, x, y, z]`, an instrument's U95 becomes
σ = U95 / 2 (a 95 % expanded uncertainty with coverage factor 2).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime
from enum import StrEnum
from typing import Any

from service.campaign_io.errors import SHOWN, CampaignFileError, listed
from service.campaign_io.tabular import Row, Table
from service.campaign_io.wide import reflector_record, split_tcp, wide_note, wide_points

MM_PER: dict[str, float] = {"mm": 1.0, "m": 1000.0, "cm": 10.0, "um": 1e-3, "µm": 1e-3, "in": 25.4, "inch": 25.4}
"""Length units a file may use, in mm: the only conversion of file lengths (the API itself takes mm)."""

DEG_PER: dict[str, float] = {"deg": 1.0, "°": 1.0, "degree": 1.0, "degrees": 1.0, "rad": 57.29577951308232}
"""Angle units a joint column may state, in degrees (the API's unit of revolute joints); radians are 180/π."""

U95_COVERAGE = 2.0

ALIASES: dict[str, tuple[str, ...]] = {
    "pose_id": (
        "pose_id",
        "pose",
        "id",
        "point_id",
        "point",
        "name",
        "point_name",
        "feature_name",
        "feature",
        "label",
        "nr",
        "nr.",
        "no",
        "no.",
        "point_no",
        "point_no.",
    ),
    "x": ("x", "meas_x", "x_meas", "measured_x", "x_measured", "actual_x", "x_actual"),
    "y": ("y", "meas_y", "y_meas", "measured_y", "y_measured", "actual_y", "y_actual"),
    "z": ("z", "meas_z", "z_meas", "measured_z", "z_measured", "actual_z", "z_actual"),
    "qw": ("qw", "w"),
    "qx": ("qx",),
    "qy": ("qy",),
    "qz": ("qz",),
    # A mocap export's per-posture scatter of its markers (`marker_std_mm`: the name, its `_mm` the unit) too.
    "sigma_mm": ("sigma_mm", "sigma", "uncertainty", "std", "std_dev", "stdev", "rms", "marker_std", "marker_sigma"),
    "u95": ("u95", "u95_mm", "expanded_uncertainty"),
    "temperature_c": ("temperature_c", "temperature", "temp", "temp.", "air_temperature", "air_temp"),
    "timestamp": ("timestamp", "time", "datetime", "date_time", "date"),
    "collection": ("collection",),
    "group": ("group",),
    "reference": ("reference", "ref", "is_reference"),
    "reflector": ("reflector", "reflector_name", "smr", "probe", "target_type"),
}
TARGET = "target"
"""A `target` column names the pose in SpatialAnalyzer's export and in joint files written to match it, but the
reflector in Leica's (`TMC 30-B #5320`, the same on every row): read as the pose id only where no other column
is one and its names are all different, else as the reflector."""
KNOWN_IGNORED = ("timestamp", "collection", "group", "reflector")
"""Columns instrument software writes that a calibration may not use: recognised, and not reported as unknown (a
time stamp is read when it is seconds or ISO 8601 on every row, for a drift-aware calibration)."""
REFERENCE_MARKS = {"1": True, "true": True, "yes": True, "x": True, "0": False, "false": False, "no": False, "": False}
"""What a `reference` cell may say (case ignored): this row measures the reference pose, or not."""


class QuaternionOrder(StrEnum):
    WXYZ = "wxyz"
    XYZW = "xyzw"


class UncertaintyKind(StrEnum):
    SIGMA = "sigma"
    U95 = "u95"


@dataclass(frozen=True)
class ImportOptions:
    length_unit: str = "mm"
    """Unit of x, y, z and uncertainties when the header does not state one."""
    quaternion_order: QuaternionOrder = QuaternionOrder.WXYZ
    """Of the columns qw/qx/qy/qz or q0…q3 when they are not named by component."""
    uncertainty: UncertaintyKind = UncertaintyKind.SIGMA
    """What a column called `uncertainty` holds; a column called `u95` is always read as U95."""
    columns: tuple[tuple[str, str], ...] = ()
    """The column map: file column (normalised) → a joint or coordinate (`service.campaign_io.columns`)."""
    joint_unit: str | None = None
    """`rad` or `deg`: the revolute joint columns' unit where the header states none (default: degrees)."""

    def __post_init__(self) -> None:
        if self.length_unit.lower() not in MM_PER:
            raise CampaignFileError(f"unknown length unit {self.length_unit!r}; use one of {', '.join(MM_PER)}")
        if self.joint_unit is not None and self.joint_unit not in ("deg", "rad"):
            raise CampaignFileError(f"unknown joint unit {self.joint_unit!r}; use deg or rad")


@dataclass(frozen=True)
class Measured:
    line: int
    pose_id: str | None
    position: list[float]
    orientation: list[float] | None
    sigma_mm: float | None
    temperature_c: float | None
    time: float | str | None = None
    reference: bool = False


def _column_map(table: Table, joint_names: Sequence[str]) -> tuple[dict[str, str], list[str]]:
    """Canonical name → the table's column; and the table's columns nobody uses."""
    columns = set(table.columns)
    found: dict[str, str] = {}
    for canonical, aliases in ALIASES.items():
        for alias in aliases:
            if alias in columns:
                found[canonical] = alias
                break
    if TARGET in columns:
        names = [row.cells.get(TARGET, "").strip() for row in table.rows]
        unique = all(names) and len(set(names)) == len(names)
        role = "pose_id" if "pose_id" not in found and unique else "reflector"
        found.setdefault(role, TARGET)
    joints = {normalise_joint(n) for n in joint_names}
    # Leica-style q0…q3 are quaternion components (q0 the scalar), unless the robot's own joints are named so and
    # the table has no q0: a joint file.
    if "q0" in columns and "qw" not in found:
        clash = sorted(joints & {"q1", "q2", "q3"} & columns)
        if clash:
            raise CampaignFileError(
                f"columns q0…q3 read as a quaternion (scalar first, as Leica writes it) clash with the robot's joints "
                f"{listed(clash)}: name the quaternion columns qw, qx, qy, qz in a table that also has joints",
                line=1,
            )
        for canonical, alias in zip(("qw", "qx", "qy", "qz"), ("q0", "q1", "q2", "q3"), strict=True):
            if alias in columns:
                found[canonical] = alias
    used = set(found.values())  # a set: `in found.values()` per joint was quadratic in a header of 20 000 joints
    for name in joints & columns:
        if name not in used:
            found[name] = name
            used.add(name)
    unknown = [c for c in table.columns if c not in used and c]
    return found, unknown


def normalise_joint(name: str) -> str:
    return name.strip().lower()


def length_factor(table: Table, column: str, options: ImportOptions) -> float:
    unit = table.units.get(column, table.length_unit or options.length_unit).lower()
    if unit not in MM_PER:
        raise CampaignFileError(
            f"column {column}: unknown length unit {unit!r} in the header; use one of {', '.join(MM_PER)}",
            column=table.column_number(column),
        )
    return MM_PER[unit]


def measured_points(
    table: Table, options: ImportOptions, joint_names: Sequence[str] = ()
) -> tuple[list[Measured], list[str]]:
    """The measured points of each row; notes say which columns were ignored and which units were converted."""
    found, unknown = _column_map(table, joint_names)
    missing = [c for c in ("x", "y", "z") if c not in found]
    if missing:
        raise CampaignFileError(f"the header has no column {listed(missing)} (found: {listed(table.columns)})", line=1)
    notes = list(table.notes)
    ignored = [c for c in unknown if c not in KNOWN_IGNORED]
    if ignored:
        notes.append(f"columns ignored (unknown): {listed(ignored)}")
    scale = length_factor(table, found["x"], options)
    if scale != 1.0:
        notes.append(f"positions converted to mm (×{scale:g})")
    quaternion = [found.get(c) for c in ("qw", "qx", "qy", "qz")]
    if any(quaternion) and not all(quaternion):
        raise CampaignFileError("give all four quaternion columns (qw, qx, qy, qz or q0…q3) or none", line=1)
    order = options.quaternion_order
    if all(quaternion) and "qw" in table.columns and order is QuaternionOrder.XYZW:
        raise CampaignFileError("the columns name the quaternion's components; quaternion_order does not apply")
    if "reflector" in found:
        notes.append(_reflector_note(table, found["reflector"]))
    times, time_note = _times(table, found.get("timestamp"))
    notes += [time_note] if time_note else []
    points = []
    for k, row in enumerate(table.rows):
        position = [table.number(row, found[c]) * scale for c in ("x", "y", "z")]
        orientation = None
        if all(quaternion):
            values = [table.number(row, str(c)) for c in quaternion]
            orientation = values if order is QuaternionOrder.WXYZ else [values[3], *values[:3]]
        points.append(
            Measured(
                line=row.line,
                pose_id=row.cells[found["pose_id"]].strip() if "pose_id" in found else None,
                position=position,
                orientation=orientation,
                sigma_mm=_sigma(table, row, found, options),
                temperature_c=table.number(row, found["temperature_c"]) if "temperature_c" in found else None,
                time=None if times is None else times[k],
                reference=_reference(table, row, found.get("reference")),
            )
        )
    return points, notes


def _reflector_note(table: Table, column: str) -> str:
    """Which reflectors the records were measured with: one per record is what a record holds (several reflectors
    on one tool are not a record kind yet), so a change of reflector is named, not silently mixed."""
    counts: dict[str, int] = {}
    for row in table.rows:
        name = row.cells.get(column, "").strip()
        counts[name] = counts.get(name, 0) + 1
    if len(counts) == 1:
        return (
            f"column {column} read as the reflector's name ({next(iter(counts))!r} on every record), not as a pose id"
        )
    listed_counts = ", ".join(f"{name!r} ×{n}" for name, n in list(counts.items())[:SHOWN])
    return (
        f"column {column} read as the reflector's name, not as a pose id: {len(counts)} reflectors ({listed_counts}); "
        "each record is one point, so every reflector must sit at the same tool offset"
    )


def _times(table: Table, column: str | None) -> tuple[list[float | str] | None, str | None]:
    """The time column as seconds (every cell a number) or ISO 8601 texts (every cell one); otherwise not read,
    and a note says why (a format of the instrument's own is no time the service can order records by)."""
    if column is None:
        return None, None
    cells = [row.cells.get(column, "").strip() for row in table.rows]
    try:
        return [float(c.replace(",", ".") if table.decimal_comma else c) for c in cells], None
    except ValueError:
        pass
    try:
        for cell in cells:
            datetime.fromisoformat(cell)
    except ValueError:
        return None, (
            f"column {column} not read as the records' time: every row needs seconds or an ISO 8601 time "
            "(2026-12-05T14:03:00) for a drift-aware calibration"
        )
    return list(cells), None


def _reference(table: Table, row: Row, column: str | None) -> bool:
    if column is None:
        return False
    cell = row.cells.get(column, "").strip().lower()
    if cell not in REFERENCE_MARKS:
        raise CampaignFileError(
            f"line {row.line}: column {column} says {cell!r}; mark a reference pose's row 1, true, yes or x, any "
            "other row 0, false, no or nothing",
            line=row.line,
            column=table.column_number(column),
        )
    return REFERENCE_MARKS[cell]


def _sigma(table: Table, row: Row, found: dict[str, str], options: ImportOptions) -> float | None:
    if "u95" in found:
        return table.number(row, found["u95"]) * length_factor(table, found["u95"], options) / U95_COVERAGE
    if "sigma_mm" in found:
        value = table.number(row, found["sigma_mm"]) * length_factor(table, found["sigma_mm"], options)
        return value / U95_COVERAGE if options.uncertainty is UncertaintyKind.U95 else value
    return None


def joint_rows(table: Table, joint_names: Sequence[str]) -> list[tuple[int, str | None, list[float]]]:
    """(line, pose id, joints) of each row; every joint of the robot must have its column."""
    found, _ = _column_map(table, joint_names)
    names = [normalise_joint(n) for n in joint_names]
    missing = [n for n in names if n not in found]
    if missing:
        raise CampaignFileError(
            f"the header has no column for the joint(s) {listed(missing)}: the robot's joints are "
            f"{listed(names)} (found: {listed(table.columns)})",
            line=1,
        )
    factors = [_joint_factor(table, n) for n in names]
    out = []
    for row in table.rows:
        pose_id = row.cells[found["pose_id"]].strip() if "pose_id" in found else None
        out.append((row.line, pose_id, [table.number(row, n) * f for n, f in zip(names, factors, strict=True)]))
    return out


def _joint_factor(table: Table, column: str) -> float:
    """A joint column's unit as its header states it (`q2 [rad]`, `q1 [m]`) to the API's (degrees for a revolute
    joint, mm for a prismatic one): 1 without a unit. An unknown unit is refused, never read as degrees."""
    unit = table.units.get(column)
    if unit is None:
        return 1.0
    if unit in DEG_PER:
        return DEG_PER[unit]
    if unit in MM_PER:
        return MM_PER[unit]
    raise CampaignFileError(
        f"column {column}: unknown joint unit {unit!r} in the header; use deg or rad for a revolute joint, "
        f"{', '.join(MM_PER)} for a prismatic one",
        column=table.column_number(column),
    )


def joint_unit_notes(table: Table, joint_names: Sequence[str]) -> list[str]:
    """What the reader converted in the joint columns (a unit other than the API's)."""
    notes = []
    for name in (normalise_joint(n) for n in joint_names):
        unit = table.units.get(name)
        if unit is not None and unit not in ("deg", "°", "degree", "degrees", "mm"):
            notes.append(f"joint column {name} is in {unit}: converted to {'degrees' if unit in DEG_PER else 'mm'}")
    return notes


def record(joints: list[float], point: Measured) -> dict[str, Any]:
    rec: dict[str, Any] = {"joints": joints, "position": point.position, "orientation": point.orientation}
    if point.sigma_mm is not None:
        rec["sigma_mm"] = point.sigma_mm
    if point.temperature_c is not None:
        rec["temperature_c"] = point.temperature_c
    if point.time is not None:
        rec["time"] = point.time
    if point.reference:
        rec["reference"] = True
    return rec


def campaign_records(
    table: Table, joint_names: Sequence[str], options: ImportOptions
) -> tuple[list[dict[str, Any]], list[str]]:
    """One table with the joints and the measurement of each pose (several points a row: `wide_records`)."""
    if wide_points(table):
        return wide_records(table, joint_names, options)
    points, notes = measured_points(table, options, joint_names)
    joints = joint_rows(table, joint_names)
    notes = [*notes, *joint_unit_notes(table, joint_names)]
    return [record(q, p) for (_, _, q), p in zip(joints, points, strict=True)], notes


def wide_records(
    table: Table, joint_names: Sequence[str], options: ImportOptions
) -> tuple[list[dict[str, Any]], list[str]]:
    """A table whose rows carry several points (`service.campaign_io.wide`): per row the TCP's tracker record,
    then a reflector record for each other point, at the row's joints and with the row's σ."""
    points = wide_points(table)
    found, _ = _column_map(table, joint_names)
    tcp_found = all(a in found for a in ("x", "y", "z"))
    view, others = split_tcp(table, points, tcp_found)
    measured, notes = measured_points(view, options, joint_names)
    joints = joint_rows(table, joint_names)
    scales = [length_factor(table, p.columns[0], options) for p in others]
    out: list[dict[str, Any]] = []
    for (_, _, q), point, row in zip(joints, measured, table.rows, strict=True):
        out.append(record(q, point))
        for other, scale in zip(others, scales, strict=True):
            position = [table.number(row, c) * scale for c in other.columns]
            out.append(reflector_record(q, other.name, position, point.sigma_mm))
    tcp = "x, y, z" if tcp_found else points[0].name
    return out, [*notes, wide_note(tcp, others), *joint_unit_notes(table, joint_names)]


def joined_records(
    joint_table: Table, point_table: Table, joint_names: Sequence[str], options: ImportOptions
) -> tuple[list[dict[str, Any]], list[str]]:
    """The controller's joint file and the instrument's point file, joined by pose id (in the joint file's order)."""
    joints = joint_rows(joint_table, joint_names)
    points, notes = measured_points(point_table, options)
    notes = [*notes, *joint_unit_notes(joint_table, joint_names)]
    if any(pid is None for _, pid, _ in joints) or any(p.pose_id is None for p in points):
        raise CampaignFileError(
            "to join a joint file and a point file both need a pose id column (pose_id, id, point, name, or target "
            "where its names are all different: a target column that repeats names the reflector)"
        )
    by_id: dict[str, Measured] = {}
    for p in points:
        if p.pose_id in by_id:
            raise CampaignFileError(f"point file line {p.line}: pose id {p.pose_id!r} appears twice", line=p.line)
        by_id[str(p.pose_id)] = p
    joint_ids = [str(pid) for _, pid, _ in joints]
    seen: set[str] = set()
    for (line, pid, _), key in zip(joints, joint_ids, strict=True):
        if key in seen:
            raise CampaignFileError(f"joint file line {line}: pose id {pid!r} appears twice", line=line)
        seen.add(key)
    only_joints = [k for k in joint_ids if k not in by_id]
    only_points = [k for k in by_id if k not in seen]
    if only_joints:
        raise CampaignFileError(
            f"{len(only_joints)} pose id(s) of the joint file have no measured point: {', '.join(only_joints[:10])}"
        )
    if only_points:
        notes.append(
            f"{len(only_points)} measured point(s) have no joints and were ignored: {', '.join(only_points[:10])}"
        )
    return [record(q, by_id[key]) for (_, _, q), key in zip(joints, joint_ids, strict=True)], notes
