"""A displacement record: a laser interferometer's reading, the signed distance (mm) the retro-reflector at the TCP
travelled along a fixed beam from the reading's zero. The beam's direction and zero are identified with the
robot (`models.measurements.line`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from models.measurements.line import Line
from service.record_kinds.base import (
    Described,
    LengthReading,
    ModelReference,
    Reading,
    RecordKind,
    described_map,
    public_form,
)
from service.schemas.common import JointVector, Position, Strict
from service.schemas.references import RecordSigma, ReferenceName

DISPLACEMENT_COLUMNS = ("displacement_mm", "displacement")
"""Where a file gives the reading (the first present is read; a unit in its header is converted)."""
DEFAULT_DIRECTION = (0.0, 0.0, 1.0)
"""A start direction where the description gives none: the fit takes the records' own (`Line.started`)."""


class LineDescription(Strict):
    """An interferometer's beam a campaign's displacement records measure along, or a pose design plans records
    on (a design needs `direction` and `origin_mm`: a record's rows are the TCP's motion along and across it)."""

    direction: Annotated[list[float], Field(min_length=3, max_length=3)] | None = Field(
        default=None,
        description="The way the readings grow, in the world frame (any length, not zero); a calibration finds it "
        "from the records, a pose design needs a guess",
    )
    origin_mm: Position | None = Field(
        default=None, description="A guess of the point where the reading is zero (mm); default: found from the records"
    )


class DisplacementRecord(Strict):
    """An interferometer's reading with the retro-reflector at the TCP on the beam named `line`."""

    kind: Literal["displacement"]
    joints: JointVector
    line: ReferenceName
    displacement_mm: float = Field(ge=-1e5, le=1e5, description="mm along the beam from the reading's zero, signed")
    sigma_mm: RecordSigma | None = None


class DisplacementKind(RecordKind):
    name: ClassVar[str] = "displacement"
    model: ClassVar[str] = Line.traits.kind
    record = DisplacementRecord
    public = public_form(DisplacementRecord)
    named_by: ClassVar[str | None] = "line"
    description = LineDescription
    described_field: ClassVar[Any] = described_map(
        20,
        "Optional: the beams displacement records name, each with a guess of its direction (a pose "
        "design needs each one's direction and origin_mm)",
    )
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {
        "direction": (
            list[float] | None,
            Field(default=None, description="A line's unit direction (an interferometer's beam)"),
        ),
        "origin_mm": (
            list[float] | None,
            Field(default=None, description="A line's point where its reading is zero, mm"),
        ),
    }
    example_name: ClassVar[str] = "l1"
    design_description: ClassVar[str] = '{"direction": [dx, dy, dz], "origin_mm": [x, y, z]}'
    reading: ClassVar[Reading | None] = LengthReading("displacement_mm", DISPLACEMENT_COLUMNS, "displacements")

    def design_reference(self, name: str, description: Any) -> ModelReference:
        if description.direction is None or math.hypot(*description.direction) == 0.0:
            raise self.lacking(
                name, "direction", "its direction, not zero (a record measures the TCP along it)", "[dx, dy, dz]"
            )
        if description.origin_mm is None:
            # Its rows across the beam turn about the origin: a ruler's guess will do, none will not.
            raise self.lacking(name, "origin_mm", "where its reading is zero (mm)", "[x, y, z]")
        dx, dy, dz = description.direction
        ox, oy, oz = description.origin_mm
        return Line(name, (dx, dy, dz), (ox, oy, oz))

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        direction, _, _ = reference.direction_at(float(values[0]), float(values[1]))
        return {"direction": [float(v) for v in direction], "origin_mm": [float(v) for v in values[2:5]]}

    def reference(self, described: Described, name: str) -> ModelReference:
        direction = self.direction_guess(
            described, name, "direction", DEFAULT_DIRECTION, give="the way its readings grow"
        )
        return Line(name, direction, self.guess(described, name, "origin_mm"))


DISPLACEMENT = DisplacementKind()
