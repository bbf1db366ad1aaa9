"""CSV in (campaigns, with the spec's header) and out (joint vectors): the codec of `text/csv` bodies."""

from __future__ import annotations

import csv
import io
from collections.abc import Sequence

from service.errors import BadRequest

CAMPAIGN_HEADER = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6", "x", "y", "z", "qw", "qx", "qy", "qz"]
JOINT_HEADER = CAMPAIGN_HEADER[:10]


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
    if header[:13] != CAMPAIGN_HEADER[:13] or header not in (CAMPAIGN_HEADER[:13], CAMPAIGN_HEADER):
        raise BadRequest(f"the CSV header must be {','.join(CAMPAIGN_HEADER)} (the last four columns optional)")
    records: list[dict[str, object]] = []
    for line, row in enumerate(rows[1:], start=2):
        cells = [c.strip() for c in row]
        if len(cells) not in (13, 17) or (len(cells) == 17 and len(header) == 13):
            raise BadRequest(f"CSV line {line}: expected {len(header)} columns, got {len(cells)}", line=line)
        try:
            numbers = [float(c) for c in cells[:13]]
            orientation = [float(c) for c in cells[13:17]] if len(cells) == 17 and all(cells[13:17]) else None
        except ValueError as exc:
            raise BadRequest(f"CSV line {line}: {exc}", line=line) from exc
        if len(cells) == 17 and any(cells[13:17]) and orientation is None:
            raise BadRequest(f"CSV line {line}: give all four of qw,qx,qy,qz or none", line=line)
        records.append({"joints": numbers[:10], "position": numbers[10:13], "orientation": orientation})
    return records


def joints_csv(rows: Sequence[Sequence[float | None]]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(JOINT_HEADER)
    for row in rows:
        writer.writerow(["" if v is None else repr(float(v)) for v in row])
    return out.getvalue()
