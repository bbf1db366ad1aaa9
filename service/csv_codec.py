"""CSV in (campaigns, with the spec's header) and out (joint vectors): the codec of `text/csv` bodies."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence

from service.errors import BadRequest

CAMPAIGN_HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
JOINT_HEADER = CAMPAIGN_HEADER[:10]
POSE_COLUMNS = ["x", "y", "z", "qw", "qx", "qy", "qz"]
LEGS = ["l1", "l2", "l3", "l4", "l5", "l6"]


def joint_header(names: Sequence[str] | None, width: int) -> list[str]:
    """The joint columns of a robot (robots.md: q1 … q_m, then l1 … l6); without its names, the IWR's for ten
    columns and q1 … q_n otherwise."""
    if names is not None:
        return list(names)
    return JOINT_HEADER if width == len(JOINT_HEADER) else [f"q{i + 1}" for i in range(width)]


def _joint_columns(header: list[str]) -> int | None:
    """How many joint columns a header of robots.md has (q1 … q_m, then optionally l1 … l6), or None."""
    m = 0
    while m < len(header) and header[m] == f"q{m + 1}":
        m += 1
    n = m + (len(LEGS) if header[m : m + len(LEGS)] == LEGS else 0)
    rest = header[n:]
    return n if n > 0 and rest in (POSE_COLUMNS[:3], POSE_COLUMNS) else None


def parse_campaign(text: str) -> list[dict[str, object]]:
    # Universal newlines: CR-only files (old Mac exports) and CRLF read like LF; csv.Error (a stray NUL, a
    # field beyond the csv module's limit) is the sender's data, so it is a 400 that names the line.
    reader = csv.reader(io.StringIO(text, newline=None))
    try:
        rows = list(reader)
    except csv.Error as exc:
        raise BadRequest(f"CSV line {reader.line_num}: {exc}", line=reader.line_num) from exc
    rows = [r for r in rows if any(cell.strip() for cell in r)]
    if not rows:
        raise BadRequest("the CSV body is empty; expected the header " + ",".join(CAMPAIGN_HEADER))
    header = [h.strip().lower() for h in rows[0]]
    # Any robot's header (robots.md): its joints, then x,y,z and optionally the quaternion; the robot checks
    # the joint count (a 422 naming its length). The IWR's is the one the message names.
    n = _joint_columns(header)
    if n is None:
        raise BadRequest(
            f"the CSV header must be {','.join(CAMPAIGN_HEADER)} (the last four columns optional; another robot's "
            "joints q1 … q_m, l1 … l6 in place of the first ten)"
        )
    short, full = n + 3, n + 7
    records: list[dict[str, object]] = []
    for line, row in enumerate(rows[1:], start=2):
        cells = [c.strip() for c in row]
        if len(cells) not in (short, full) or (len(cells) == full and len(header) == short):
            raise BadRequest(f"CSV line {line}: expected {len(header)} columns, got {len(cells)}", line=line)
        try:
            numbers = [float(c) for c in cells[:short]]
            quat = cells[short:full]
            orientation = [float(c) for c in quat] if len(cells) == full and all(quat) else None
        except ValueError as exc:
            raise BadRequest(f"CSV line {line}: {exc}", line=line) from exc
        if len(cells) == full and any(quat) and orientation is None:
            raise BadRequest(f"CSV line {line}: give all four of qw,qx,qy,qz or none", line=line)
        records.append({"joints": numbers[:n], "position": numbers[n:short], "orientation": orientation})
    return records


def joints_csv(rows: Sequence[Sequence[float | None]], names: Sequence[str] | None = None) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(joint_header(names, len(rows[0]) if rows else len(JOINT_HEADER)))
    for row in rows:
        writer.writerow(["" if v is None else repr(float(v)) for v in row])
    return out.getvalue()
