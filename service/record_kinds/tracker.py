"""A laser tracker's record: the TCP's position (and, with a 6-DOF probe, its orientation) in the instrument's
frame. A campaign of them alone is the models' pose or position campaign; beside other kinds, their positions
fix the frame."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from models.measurement import MeasurementKind
from models.measurements.references import TrackerPositions
from service.campaign_io.errors import CampaignFileError, listed
from service.campaign_io.records import length_factor
from service.record_kinds.base import Described, FileRow, ModelReference, RecordKind, cell
from service.schemas.calibrations import Record
from service.schemas.campaigns import CampaignRecordPublic

POSITION_COLUMNS = ("x", "y", "z")


class TrackerKind(RecordKind):
    name: ClassVar[str] = "tracker"
    model: ClassVar[str] = TrackerPositions.traits.kind
    measurement_kinds: ClassVar[tuple[MeasurementKind, ...]] = (MeasurementKind.POSE, MeasurementKind.POSITION)
    record = Record
    public = CampaignRecordPublic
    label: ClassVar[str] = "tracker"
    file_kinds: ClassVar[tuple[str, ...]] = ("tracker", "", "position")
    file_columns: ClassVar[tuple[str, ...]] = (*POSITION_COLUMNS, "sigma_mm")

    def reference(self, described: Described, name: str) -> ModelReference:
        return TrackerPositions()

    def values(self, records: Sequence[Any]) -> np.ndarray:
        return np.array([r.position for r in records], dtype=float)

    def notes(self, records: Sequence[Any]) -> list[str]:
        if any(r.orientation is not None for r in records):
            return [
                "the tracker records' orientations are not used beside distance, point or plane records: their "
                "positions fix the frame"
            ]
        return []

    def read_row(self, row: FileRow, out: list[dict[str, Any]]) -> None:
        table = row.table
        missing = [c for c in POSITION_COLUMNS if c not in table.columns]
        if missing:
            raise CampaignFileError(
                f"line {row.row.line}: a tracker record needs the columns x, y, z (missing: {listed(missing)})",
                line=row.row.line,
            )
        scale = length_factor(table, "x", row.options)
        rec: dict[str, Any] = {
            "joints": row.joints,
            "position": [table.number(row.row, c) * scale for c in POSITION_COLUMNS],
        }
        row.sigma_mm(rec)
        out.append(rec)

    def file_rows(self, record: Any) -> list[dict[str, str]]:
        # The layout of several kinds carries a tracker record's position and σ; its orientation and temperature
        # only the tracker layout does (a campaign of tracker records alone is written in it).
        x, y, z = (cell(v) for v in record.position)
        return [{"kind": self.file_kinds[0], "x": x, "y": y, "z": z, "sigma_mm": cell(record.sigma_mm)}]


TRACKER = TrackerKind()
