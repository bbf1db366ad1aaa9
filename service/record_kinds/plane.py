"""A plane record: the TCP (a probe's ball centre, its radius already added) touching one unknown plane."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from models.measurements.references import Plane
from service.record_kinds.base import Described, ModelReference, RecordKind, described_map, public_form
from service.schemas.common import JointVector, Strict
from service.schemas.references import PlaneDescription, RecordSigma, ReferenceName

DEFAULT_PLANE_SIDE = (0.0, 0.0, 1.0)
"""The side a plane is taken to be touched from when its description gives none (the fit's sign only)."""


class PlaneRecord(Strict):
    """The TCP (a probe's ball centre, its radius already added) touching one unknown plane."""

    kind: Literal["plane"]
    joints: JointVector
    plane: ReferenceName
    sigma_mm: RecordSigma | None = None


class PlaneKind(RecordKind):
    name: ClassVar[str] = "plane"
    model: ClassVar[str] = Plane.traits.kind
    record = PlaneRecord
    public = public_form(PlaneRecord)
    named_by: ClassVar[str | None] = "plane"
    description = PlaneDescription
    described_field: ClassVar[Any] = described_map(
        100,
        "Optional: the side each plane is touched from (a pose design needs each one's normal)",
    )
    report_fields: ClassVar[Mapping[str, tuple[Any, Any]]] = {
        "normal": (list[float] | None, Field(default=None, description="A plane's unit normal")),
        "offset_mm": (
            float | None,
            Field(default=None, description="A plane's distance from the origin along its normal"),
        ),
    }
    example_name: ClassVar[str] = "f1"
    design_description: ClassVar[str] = '{"normal": [nx, ny, nz]}'

    def design_reference(self, name: str, description: Any) -> ModelReference:
        if description.normal is None or math.hypot(*description.normal) == 0.0:
            raise self.lacking(
                name, "normal", "its normal, not zero (a touch measures the TCP along it)", "[nx, ny, nz]"
            )
        nx, ny, nz = description.normal
        return Plane(name, (nx, ny, nz), 0.0)

    def reported(self, reference: Any, values: np.ndarray) -> dict[str, Any]:
        normal, _, _ = reference.normal_at(float(values[0]), float(values[1]))
        return {"normal": [float(v) for v in normal], "offset_mm": float(values[2])}

    def reference(self, described: Described, name: str) -> ModelReference:
        normal = self.direction_guess(described, name, "normal", DEFAULT_PLANE_SIDE, give="the side it is touched from")
        return Plane(name, normal, 0.0)


PLANE = PlaneKind()
