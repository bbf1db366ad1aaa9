"""A point record: the TCP on the same unknown fixed point as every record of that name (a sphere in a socket,
reached in several orientations): no reading at all."""

from __future__ import annotations

from typing import Any, ClassVar, Literal

import numpy as np

from models.measurements.references import FixedPoint
from service.record_kinds.base import Described, ModelReference, RecordKind, described_map, public_form
from service.schemas.common import JointVector, Strict
from service.schemas.references import PointDescription, RecordSigma, ReferenceName


class PointRecord(Strict):
    """The TCP on the same unknown fixed point as every record of that name (a sphere in a socket, reached in
    several orientations): no reading at all."""

    kind: Literal["point"]
    joints: JointVector
    point: ReferenceName
    sigma_mm: RecordSigma | None = None


class PointKind(RecordKind):
    name: ClassVar[str] = "point"
    model: ClassVar[str] = FixedPoint.traits.kind
    record = PointRecord
    public = public_form(PointRecord)
    named_by: ClassVar[str | None] = "point"
    description = PointDescription
    described_field: ClassVar[Any] = described_map(
        100,
        "Optional guesses of the fixed points' positions (a pose design: the points records would be on)",
    )
    example_name: ClassVar[str] = "p1"

    def design_reference(self, name: str, description: Any) -> ModelReference:
        px, py, pz = description.position_mm or (0.0, 0.0, 0.0)  # its rows do not depend on where it is
        return FixedPoint(name, (px, py, pz))

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        return {"position_mm": [float(v) for v in values[:3]]}

    def reference(self, described: Described, name: str) -> ModelReference:
        return FixedPoint(name, self.guess(described, name, "position_mm"))


POINT = PointKind()
