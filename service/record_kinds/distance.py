"""A distance record: the TCP's distance to a fixed anchor (a ballbar's centre pivot, a wire or laser sensor's
origin)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar, Literal, cast

import numpy as np
from pydantic import Field

from models.measurements.references import Anchor
from service.campaign_io.errors import CampaignFileError
from service.campaign_io.records import ImportOptions, length_factor
from service.campaign_io.tabular import Table
from service.errors import BadRequest
from service.record_kinds.base import Described, FileRow, ModelReference, RecordKind, cell, first_column
from service.schemas.common import JointVector, Public, Strict
from service.schemas.references import AnchorDescription, RecordSigma, ReferenceName

DISTANCE_COLUMNS = ("distance_mm", "distance", "length")
"""Where a file gives the distance (the first present is read; a unit in its header is converted)."""


class DistanceRecord(Strict):
    """The TCP's distance to a fixed anchor: a ballbar's centre pivot, a wire or laser sensor's origin."""

    kind: Literal["distance"]
    joints: JointVector
    anchor: ReferenceName
    distance_mm: float = Field(gt=0, le=1e5, description="mm; with the anchor's length_unknown, up to an offset")
    sigma_mm: RecordSigma | None = None


class DistanceRecordPublic(Public):
    kind: Literal["distance"]
    joints: list[float]
    anchor: str
    distance_mm: float
    sigma_mm: float | None = None


class DistanceKind(RecordKind):
    name: ClassVar[str] = "distance"
    model: ClassVar[str] = Anchor.traits.kind
    record = DistanceRecord
    public = DistanceRecordPublic
    named_by: ClassVar[str | None] = "anchor"
    label: ClassVar[str] = "anchor"
    described_in: ClassVar[str | None] = "anchors"
    description = AnchorDescription
    described_field: ClassVar[Any] = Field(
        default_factory=dict,
        max_length=100,
        description="Every anchor a distance record names (a ballbar pivot, a sensor's origin), with an optional "
        "guess of its position and whether the bar's length offset is unknown; a pose design needs each one's "
        "position_mm, optionally range_mm",
    )
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {
        "length_offset_mm": (
            float | None,
            Field(default=None, description="An anchor with length_unknown: its offset"),
        ),
    }
    example_name: ClassVar[str] = "a1"
    design_description: ClassVar[str] = '{"position_mm": [x, y, z]}'
    sampled: ClassVar[bool] = True
    more_candidates: ClassVar[str] = "widen its range_mm or raise candidate_count"
    readable_filter: ClassVar[str | None] = "range_mm"
    file_kinds: ClassVar[tuple[str, ...]] = ("distance",)
    file_columns: ClassVar[tuple[str, ...]] = ("distance_mm", "sigma_mm")

    def check_described(self, described: Described, name: str, record: int) -> None:
        if name not in self.descriptions(described):
            raise BadRequest(
                f"record {record} measures anchor {name!r}, which the campaign does not describe: add "
                f'"anchors": {{"{name}": {{}}}} (with "length_unknown": true for a ballbar whose length offset is '
                "not known)",
                record=record,
            )

    def design_reference(self, name: str, description: Any) -> ModelReference:
        if description.position_mm is None:
            # A tape's guess will do: the rows' directions hardly turn over centimetres.
            raise self.lacking(
                name,
                "position_mm",
                "where it stands (its records' rows depend on the direction to the TCP)",
                "[x, y, z]",
            )
        x, y, z = description.position_mm
        return Anchor(name, (x, y, z), length_unknown=description.length_unknown)

    def readable(self, reference: ModelReference, description: Any, tcp: np.ndarray) -> np.ndarray | None:
        """Where the nominal TCP's distance to the anchor lies in its `range_mm` (a ballbar's travel)."""
        if description.range_mm is None:
            return None
        low, high = description.range_mm
        distance = np.linalg.norm(tcp - np.asarray(cast(Anchor, reference).start), axis=1)
        return np.asarray((distance >= low) & (distance <= high))

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        entry: dict[str, Any] = {"position_mm": [float(v) for v in values[:3]]}
        if reference.length_unknown:
            entry["length_offset_mm"] = float(values[3])
        return entry

    def reference(self, described: Described, name: str) -> ModelReference:
        anchor = self.descriptions(described)[name]
        x, y, z = anchor.position_mm or (0.0, 0.0, 0.0)
        return Anchor(name, (x, y, z), length_unknown=anchor.length_unknown)

    def values(self, records: Sequence[Any]) -> np.ndarray:
        return np.array([r.distance_mm for r in records], dtype=float)

    def table_notes(self, table: Table, options: ImportOptions) -> list[str]:
        distance = first_column(table, DISTANCE_COLUMNS)
        scale = length_factor(table, distance, options) if distance else 1.0
        return [f"distances converted to mm (×{scale:g})"] if scale != 1.0 else []

    def read_row(self, row: FileRow, out: list[dict[str, Any]]) -> None:
        distance = first_column(row.table, DISTANCE_COLUMNS)
        if distance is None:
            raise CampaignFileError(f"line {row.row.line}: a distance record needs a distance_mm column", line=1)
        scale = length_factor(row.table, distance, row.options)
        rec: dict[str, Any] = {"kind": self.name, "joints": row.joints, "anchor": row.name}
        rec["distance_mm"] = row.table.number(row.row, distance) * scale
        row.sigma_mm(rec)
        out.append(rec)

    def file_rows(self, record: Any) -> list[dict[str, str]]:
        return [
            {
                "kind": self.file_kinds[0],
                "reference": record.anchor,
                "distance_mm": cell(record.distance_mm),
                "sigma_mm": cell(record.sigma_mm),
            }
        ]


DISTANCE = DistanceKind()
