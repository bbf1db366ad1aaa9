"""A distance record: the TCP's distance to a fixed anchor (a ballbar's centre pivot, a wire or laser sensor's
origin)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar, Literal, cast

import numpy as np
from pydantic import Field

from models.measurements.references import Anchor
from service.record_kinds.base import (
    Described,
    LengthReading,
    ModelReference,
    MustDescribe,
    Reading,
    RecordKind,
    described_map,
    public_form,
)
from service.schemas.common import JointVector, Strict
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


class DistanceKind(RecordKind):
    name: ClassVar[str] = "distance"
    model: ClassVar[str] = Anchor.traits.kind
    record = DistanceRecord
    public = public_form(DistanceRecord)
    named_by: ClassVar[str | None] = "anchor"
    description = AnchorDescription
    described_field: ClassVar[Any] = described_map(
        100,
        "Every anchor a distance record names (a ballbar pivot, a sensor's origin), with an optional "
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
    must_describe: ClassVar[MustDescribe | None] = MustDescribe(
        "measures anchor", "{}", 'with "length_unknown": true for a ballbar whose length offset is not known'
    )
    reading: ClassVar[Reading | None] = LengthReading("distance_mm", DISTANCE_COLUMNS, "distances")

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
        length_unknown = self.descriptions(described)[name].length_unknown  # `check_described`: it is described
        return Anchor(name, self.guess(described, name, "position_mm"), length_unknown=length_unknown)


DISTANCE = DistanceKind()
