"""The parameters export as CSV and back: one row per parameter, values printed exactly (repr of the float), so
a re-import gives the same numbers to the last bit."""

from __future__ import annotations

import csv
import io
from typing import Any

from service.errors import BadRequest
from service.schemas.robots import ParametersPublic

PARAMETER_HEADER = ["name", "value", "unit", "nominal", "std_error", "identifiable"]


def _number(value: float | None) -> str:
    return "" if value is None else repr(float(value))


def parameters_csv(parameters: ParametersPublic) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(PARAMETER_HEADER)
    for p in parameters.parameters:
        flag = "" if p.identifiable is None else str(p.identifiable).lower()
        writer.writerow([p.name, _number(p.value), p.unit, _number(p.nominal), _number(p.std_error), flag])
    return out.getvalue()


def parse_parameters(text: str) -> dict[str, Any]:
    """The CSV export as the JSON body of an import (validated by the schema afterwards)."""
    reader = csv.reader(io.StringIO(text, newline=None))
    try:
        rows = [r for r in reader if any(c.strip() for c in r)]
    except csv.Error as exc:
        raise BadRequest(f"CSV line {reader.line_num}: {exc}", line=reader.line_num) from exc
    if not rows or [h.strip().lower() for h in rows[0]][:2] != PARAMETER_HEADER[:2]:
        raise BadRequest(
            "the CSV header must start name,value (the export's header: " + ",".join(PARAMETER_HEADER) + ")"
        )
    header = [h.strip().lower() for h in rows[0]]
    unknown = [h for h in header if h not in PARAMETER_HEADER]
    if unknown:
        raise BadRequest(f"unknown CSV column {unknown[0]!r}; the columns are {','.join(PARAMETER_HEADER)}", line=1)
    parameters: list[dict[str, Any]] = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise BadRequest(f"CSV line {line}: expected {len(header)} columns, got {len(row)}", line=line)
        cells = dict(zip(header, (c.strip() for c in row), strict=True))
        entry: dict[str, Any] = {"name": cells["name"]}
        try:
            entry["value"] = float(cells["value"])
            for key in ("nominal", "std_error"):
                if cells.get(key):
                    entry[key] = float(cells[key])
        except ValueError as exc:
            raise BadRequest(f"CSV line {line}: {exc}", line=line) from exc
        if cells.get("unit"):
            entry["unit"] = cells["unit"]
        flag = cells.get("identifiable", "").lower()
        if flag:
            if flag not in ("true", "false"):
                raise BadRequest(f"CSV line {line}: identifiable must be true, false or empty, not {flag!r}", line=line)
            entry["identifiable"] = flag == "true"
        parameters.append(entry)
    return {"parameters": parameters}
