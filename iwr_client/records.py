"""Tracker records from a CSV file, for the one request that takes JSON only (an adaptive campaign's records).

The columns are the campaign file's (examples/campaign.csv): the robot's joint names, then x, y, z (mm) and,
optionally, the orientation qw, qx, qy, qz and a per-record `sigma_mm` and `temperature_c`. Calibrations,
validations and quick checks send the file itself (`text/csv`), read by the service's tolerant reader (column
maps, units, tracker exports); this reader is only the strict subset of it that an adaptive campaign's posted
records need."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from typing import Any

from iwr_client.errors import CampaignFileError

POSITION = ("x", "y", "z")
ORIENTATION = ("qw", "qx", "qy", "qz")
OPTIONAL = ("sigma_mm", "temperature_c")


def _number(text: str, row: int, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise CampaignFileError(f"row {row}, column {column}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise CampaignFileError(f"row {row}, column {column}: {text!r} is not a finite number")
    return value


def records_from_csv(text: str, joint_names: Sequence[str]) -> list[dict[str, Any]]:
    """One record per data row: {"joints", "position"[, "orientation", "sigma_mm", "temperature_c"]}."""
    reader = csv.DictReader(io.StringIO(text))
    header = [name.strip() for name in reader.fieldnames or []]
    reader.fieldnames = header
    missing = [name for name in (*joint_names, *POSITION) if name not in header]
    if missing:
        raise CampaignFileError(f"the header lacks {', '.join(missing)} (it has {', '.join(header) or 'nothing'})")
    oriented = all(name in header for name in ORIENTATION)
    records: list[dict[str, Any]] = []
    for row_number, row in enumerate(reader, start=2):  # the header is row 1
        if not any((value or "").strip() for value in row.values()):
            continue
        if None in row or any(value is None for value in row.values()):
            raise CampaignFileError(f"row {row_number} has {len(row)} fields, not the header's {len(header)}")
        record: dict[str, Any] = {
            "joints": [_number(row[name], row_number, name) for name in joint_names],
            "position": [_number(row[name], row_number, name) for name in POSITION],
        }
        if oriented:
            record["orientation"] = [_number(row[name], row_number, name) for name in ORIENTATION]
        for name in OPTIONAL:
            if (row.get(name) or "").strip():
                record[name] = _number(row[name], row_number, name)
        records.append(record)
    if not records:
        raise CampaignFileError("the file has a header and no records")
    return records
