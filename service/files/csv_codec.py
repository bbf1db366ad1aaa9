"""CSV in (campaigns, read tolerantly by `service.campaign_io`) and out (joint vectors): the `text/csv` codec."""

from __future__ import annotations

import csv
import functools
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
from service.campaign_io.columns import RobotColumns, mapped, missing_columns, with_joint_unit, with_length_unit
from service.campaign_io.errors import listed
from service.campaign_io.reference_table import is_reference_table, reference_records
from service.campaign_io.tabular import Table

CAMPAIGN_HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
JOINT_HEADER = CAMPAIGN_HEADER[:10]
POSE_COLUMNS = ["x", "y", "z", "qw", "qx", "qy", "qz"]
LEGS = ["l1", "l2", "l3", "l4", "l5", "l6"]


def parse_campaign(
    text: str, *, options: ImportOptions | None = None, robot: RobotColumns | None = None
) -> tuple[list[dict[str, object]], list[str]]:
    """A `text/csv` campaign body as the API's records, read by the tolerant reader (BOM, `;` or tab, decimal
    commas, comments, columns by name in any order, units in the header), and the reader's notes (columns
    ignored, units converted). The header names the robot's joints (robots.md: q1 … q_m, l1 … l6; A1 …, J1 …,
    joint_1 …, panda_joint1 …; with `robot`, its URDF's names too; the robot checks their count, a 422 naming its
    length), or the options' column map names them, and x, y, z [, qw, qx, qy, qz] [, sigma_mm] [,
    temperature_c] (kept on each record: the thermal model term uses it, the score test after a geometric fit
    reads it)."""
    options = options or ImportOptions()
    table, notes = mapped(read_table(text, expected=CAMPAIGN_HEADER), options.columns, robot)
    names = joint_columns(table.columns, robot)
    table = _joint_units(table, names, robot, options)
    if is_reference_table(table):  # a `kind` column: distance, point, plane and tracker rows
        records, more = reference_records(table, names, options)
    else:
        records, more = campaign_records(table, names, options)
    return records, [*notes, *more]


def joined_campaign(
    joints: str,
    points: str,
    *,
    spatial_analyzer: bool,
    options: ImportOptions | None = None,
    robot: RobotColumns | None = None,
) -> tuple[list[dict[str, object]], list[str]]:
    """The controller's joint file and the instrument's point file (CSV or SpatialAnalyzer's ASCII export),
    joined by pose id, as the API's records and the reader's notes."""
    options = options or ImportOptions()
    point_table = read_spatial_analyzer(points) if spatial_analyzer else read_table(points)
    joint_table = read_table(joints)
    missing_columns(options.columns, joint_table, point_table)
    joint_table, joint_notes = mapped(joint_table, options.columns, robot, required=False)
    point_table, point_notes = mapped(point_table, options.columns, None, required=False)
    names = joint_columns(joint_table.columns, robot)
    joint_table = _joint_units(joint_table, names, robot, options)
    records, notes = joined_records(joint_table, point_table, names, options)
    return records, [*joint_notes, *point_notes, *notes]


def _joint_units(table: Table, names: Sequence[str], robot: RobotColumns | None, options: ImportOptions) -> Table:
    """The joint columns' units where the header states none: `joint_unit` on the revolute ones, the file's
    length unit (its preamble's, else `length_unit`) on the prismatic ones."""
    revolute = _revolute(names, robot)
    table = with_joint_unit(table, revolute, options.joint_unit)
    turning = set(revolute)  # a set: a header of thousands of joints is refused in linear time, not quadratic
    prismatic = [n for n in names if n not in turning]
    return with_length_unit(table, prismatic, table.length_unit or options.length_unit)


def _revolute(names: Sequence[str], robot: RobotColumns | None) -> list[str]:
    """The joint columns a `joint_unit` applies to: the robot's revolute joints; without the robot, the serial
    joints (a hexapod's legs are lengths)."""
    if robot is None:
        return [n for n in names if n not in LEGS]
    revolute = set(robot.revolute)
    if list(names) == list(robot.names):
        return [n for n in names if n in revolute]
    turning = [k for k, n in enumerate(robot.names) if n in revolute]
    return [names[k] for k in turning if k < len(names)]


JOINT_STYLES = ("q", "a", "j", "axis", "joint")
"""How a header may number the serial joints, 1-based: q1 … (robots.md), A1 … (KUKA), J1 … (ABB, Fanuc), axis1 …
and joint1 … (case does not matter: the reader lowers it), each with a URDF's prefix and underscore as ROS writes
them (`joint_1` in ROS-Industrial's URDFs, `panda_joint1`, `a_1`). One style a file."""
NUMBERED = re.compile(r"((?:[a-z][a-z0-9]*_)*(?:q|a|j|axis|joint)_?)([1-9][0-9]*)")


def joint_columns(columns: Sequence[str], robot: RobotColumns | None = None) -> list[str]:
    """The joint columns a header names, in the robot's order: the robot's own names where the header has them
    all (q1 …, or its URDF's once `mapped` renamed them), else the serial joints 1 … m in one numbering style,
    then a hexapod's legs l1 … l6 (a Leica q0…q3 quaternion is not joints: q0 marks it)."""
    if robot is not None and all(n in columns for n in robot.names):
        return list(robot.names)
    if "q0" in columns:
        return JOINT_HEADER  # a Leica-style q0…q3 quaternion: the reader names the clash with the joints
    styles: dict[str, list[str]] = {}
    for c in columns:
        found = NUMBERED.fullmatch(c)
        if found is not None:
            styles.setdefault(found.group(1), []).append(c)
    for prefix, found_columns in styles.items():
        found_columns.sort(key=functools.partial(_number, len(prefix)))
    used = list(styles)
    legs = [leg for leg in LEGS if leg in columns]
    if len(used) > 1:
        raise CampaignFileError(
            f"the header numbers its joints in more than one way ({listed([styles[u][0] for u in used])}): "
            "name them all alike, e.g. q1 … q_m or A1 … A_m, or say which is which with a column map "
            "(columns=J1=q1,…)",
            line=1,
        )
    if not used and not legs:
        urdf = (
            f"; this robot's URDF names are read too: {listed(sorted(set(robot.aliases)))}"
            if robot and robot.aliases
            else ""
        )
        raise CampaignFileError(
            "the header names no joint column: name the robot's joints q1 … q_m in its order (A1 …, J1 …, axis1 …, "
            f"joint1 …, joint_1 … and panda_joint1 … are read too; a hexapod's legs are l1 … l6){urdf}, or map "
            f"the file's columns to them (columns=Axis 1=q1,…); found: {listed(columns)}",
            line=1,
        )
    style = used[0] if used else "q"
    serial = styles.get(style, [])
    expected = [f"{style}{k + 1}" for k in range(len(serial))]
    if serial != expected:
        missing = sorted(set(expected) - set(serial), key=lambda c: int(c[len(style) :]))
        raise CampaignFileError(f"the joint columns skip {listed(missing)}: number them 1 … m in order", line=1)
    return serial + legs


def _number(prefix_length: int, column: str) -> int:
    return int(column[prefix_length:])


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
