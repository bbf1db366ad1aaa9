"""Parameter versions: the list, a diff of two, restore and import (boundary units: mm, degrees)."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from service.schemas.common import PARAMETER_UNITS, ConditionsPublic, OptionalFloat, Public, Strict, optional

Provenance = Literal["nominal", "calibration", "restore", "import", "edit"]


class ParameterVersionPublic(Public):
    version: int
    provenance: Provenance = Field(
        description="nominal (version 1), calibration (an applied calibration), restore (a copy of "
        "`restored_from`), import (values sent to …/parameter-versions), edit (new base or tool guesses by PATCH)"
    )
    calibration_id: str | None = Field(description="The calibration that produced it (provenance calibration)")
    restored_from: int | None = Field(description="The version it copies (provenance restore)")
    created_at: datetime
    actor: str | None = Field(description="Name of the API key that made it (never the key); null without keys")
    current: bool
    conditions: ConditionsPublic | None = optional(
        "What the campaign that made it was measured under: checks and compensations outside these "
        "ranges carry a warning; null: no campaign made it (or it was made before conditions were kept)"
    )


class ParameterDiffPublic(Public):
    name: str
    unit: PARAMETER_UNITS
    a: float = Field(description="Value in version a")
    b: float = Field(description="Value in version b")
    difference: float = Field(description="b − a")
    std_error_a: OptionalFloat = Field(description="Null where version a did not estimate it (exact for the diff)")
    std_error_b: OptionalFloat
    std_error: OptionalFloat = Field(
        description="Combined std error of the difference, sqrt(σa² + σb²) over the versions that estimated it "
        "(the two estimates come from different campaigns, so they are taken as independent); null when neither did"
    )
    difference_sigma: OptionalFloat = Field(description="difference / std_error; null without a std error")
    registration: bool = Field(
        default=False,
        description="The base: where the instrument stood relative to the robot (registration), not its geometry",
    )


class VersionDiffPublic(Public):
    robot_id: str
    a: int
    b: int
    parameters: list[ParameterDiffPublic]
    changed: list[str] = Field(description="Names whose values differ")
    max_abs_sigma: OptionalFloat = Field(description="Largest |difference_sigma|; null when no std error is known")
    geometry_max_abs_sigma: OptionalFloat = optional(
        "Largest |difference_sigma| of the robot's geometry, the registration (base) left out: what "
        "changed in the robot rather than where the instrument stood"
    )


class ParameterValueIn(Strict):
    name: str = Field(min_length=1, max_length=100)
    value: float = Field(description="mm or deg, as the parameters export states it")
    unit: PARAMETER_UNITS | None = optional("When given, checked against the robot's")
    std_error: float | None = Field(default=None, ge=0)
    identifiable: bool | None = None
    nominal: float | None = optional("Ignored: the robot's own nominal is kept")


class ParameterVersionImport(Strict):
    """The JSON export of GET …/parameters (or the same as CSV): every parameter of the robot, once."""

    version: int | None = optional("Ignored (the export's own version)")
    provenance: str | None = optional("Ignored")
    calibration_id: str | None = optional("Ignored")
    parameters: list[ParameterValueIn] = Field(min_length=1, max_length=10_000)
