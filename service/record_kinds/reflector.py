"""A reflector record: the tracker's reading, in its frame, of a second or third reflector fixed on the tool at an
unknown offset from the TCP (a three-reflector nest, a probe with several targets), beside the TCP's own
tracker records. Its offset is identified with the robot; with the TCP's records it shows the tool's turn, as a
6-DOF probe would."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from models.measurements.references import Reflector
from service.record_kinds.base import (
    POSITION,
    Described,
    ModelReference,
    Reading,
    RecordKind,
    described_map,
    public_form,
)
from service.schemas.common import JointVector, Position, Strict
from service.schemas.references import RecordSigma, ReferenceName, ReflectorDescription


class ReflectorRecord(Strict):
    """Where the tracker read the reflector named `reflector` at these joints (its frame, mm)."""

    kind: Literal["reflector"]
    joints: JointVector
    reflector: ReferenceName
    position: Position = Field(description="mm, in the tracker's frame (as a tracker record's position)")
    sigma_mm: RecordSigma | None = None


class ReflectorKind(RecordKind):
    name: ClassVar[str] = "reflector"
    model: ClassVar[str] = Reflector.traits.kind
    record = ReflectorRecord
    public = public_form(ReflectorRecord)
    named_by: ClassVar[str | None] = "reflector"
    description = ReflectorDescription
    described_field: ClassVar[Any] = described_map(
        20,
        "Optional guesses of where the reflectors that reflector records name sit from the TCP (a pose "
        "design needs each one's offset_mm)",
    )
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {
        "tool_offset_mm": (
            list[float] | None,
            Field(default=None, description="A reflector's offset from the TCP, mm, in the TCP frame"),
        ),
    }
    example_name: ClassVar[str] = "r2"
    design_description: ClassVar[str] = '{"offset_mm": [x, y, z]}'
    sampled: ClassVar[bool] = True
    reading: ClassVar[Reading | None] = POSITION

    def design_reference(self, name: str, description: Any) -> ModelReference:
        if description.offset_mm is None:
            # Its rows turn with the tool by the offset: a ruler's guess will do, none will not.
            raise self.lacking(name, "offset_mm", "where it sits on the tool (from the TCP, mm)", "[x, y, z]")
        x, y, z = description.offset_mm
        return Reflector(name, (x, y, z))

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        return {"tool_offset_mm": [float(v) for v in values[:3]]}

    def reference(self, described: Described, name: str) -> ModelReference:
        return Reflector(name, self.guess(described, name, "offset_mm"))


REFLECTOR = ReflectorKind()
