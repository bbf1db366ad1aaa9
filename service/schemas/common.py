"""Shared request/response pieces.

Requests forbid unknown fields and non-finite numbers. Responses forbid unknown fields too, so a conversion
that builds a key the schema does not declare fails at once, and the published OpenAPI lists every key.
"""

from __future__ import annotations

import math
from datetime import datetime
from enum import StrEnum
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, Field, TypeAdapter, model_validator

from models.measurement import MeasurementKind


def values_of(enum: type[StrEnum]) -> Any:
    """A field type for one of the enum's members, published as the `Literal` of its values would be.

    An enum type itself would move the field's schema to a `$ref` component (a change of the contract) and word
    its 422 otherwise; the Literal keeps the inline `enum` of strings and its message, the validator hands the
    code the member. Modules alias the result under `TYPE_CHECKING` (mypy sees the enum, which is what the field
    holds), since a type built at run time is no type to mypy."""
    return Annotated[Literal[tuple(member.value for member in enum)], AfterValidator(enum)]


if TYPE_CHECKING:
    Measurement = MeasurementKind
else:
    Measurement = values_of(MeasurementKind)


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Public(BaseModel):
    model_config = ConfigDict(extra="forbid")


STRICT_BY_ALIAS = ConfigDict(extra="forbid", allow_inf_nan=False, validate_by_name=True, serialize_by_alias=True)
"""Strict's config for a body with a field whose name on the wire would shadow an attribute of the model or is a
keyword (`register`, `import`): the wire name is the field's alias, the code uses the field's own name."""


NOTES_MAX = 10_000

FreeText = Annotated[
    str,
    Field(max_length=NOTES_MAX, pattern=r"^[^\x00-\x08\x0b\x0c\x0e-\x1f\x7f]*$"),
]
"""Free text (notes): lines and tabs, no other control character. PostgreSQL text cannot hold NUL (psycopg's
DataError was a 500, where SQLite stored it), and the others are nobody's notes but a terminal's escapes."""


def exactly_one(first: str, second: str, message: str) -> Any:
    """The model validator of two optional fields of which a body gives one, not both nor neither."""

    def check(model: Any) -> Any:
        if (getattr(model, first) is None) == (getattr(model, second) is None):
            raise ValueError(message)
        return model

    return model_validator(mode="after")(check)


def short_name(description: str, example: str, pattern: str = r"^[A-Za-z0-9_-]+$") -> Any:
    """The field of a short name the user gives a thing (a reference, a branch, a solid), which the service then
    builds other names from (parameters, tools) or quotes back (a refusal): 1 to 64 characters matching `pattern`."""
    return Field(min_length=1, max_length=64, pattern=pattern, description=description, examples=[example])


ImportNotes = Annotated[
    list[str],
    Field(
        default_factory=list,
        max_length=100,
        description="What the file reader noted (columns ignored, units converted); set by the service for CSV",
    ),
]
"""A campaign request's notes from the file its records were read from (service.files.campaign_requests): the same
field in every body that may come as a file (a calibration, a validation, a quick check)."""
ImportNotesPublic = Annotated[
    list[str],
    Field(
        default_factory=list,
        description="What the file reader noted (columns mapped, units converted); empty for records sent as JSON",
    ),
]
"""The same notes as a stored validation or quick check answers them."""


def optional(description: str) -> Any:
    """A field that may be left out and is then null: the service's default in a request, "none" in a response
    (its description says which)."""
    return Field(default=None, description=description)


def _is_none(value: object) -> bool:
    return value is None


def absent_if_none(description: str | None = None) -> Any:
    """A response field whose key is left out of the JSON where it holds nothing (rather than written as null):
    a key that does not apply to this answer (an orientation for a position-only campaign)."""
    return Field(default=None, exclude_if=_is_none, description=description)


def _finite_or_none(value: Any) -> Any:
    # The one place NaN and infinities become null: strict JSON (and PostgreSQL's JSON type) has no such numbers.
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


OptionalFloat = Annotated[float | None, BeforeValidator(_finite_or_none)]
"""A number, or null where the mathematics has none (a NaN standard error, an infinite condition number)."""


_DATETIME = TypeAdapter(datetime)


def timestamp(value: datetime) -> str:
    """A datetime as every response model serialises it (RFC 3339, `Z` for UTC)."""
    return str(_DATETIME.dump_python(value, mode="json"))


JointValue = Annotated[float, Field(ge=-1e6, le=1e6)]
JointVector = Annotated[
    list[JointValue],
    Field(
        min_length=1,
        max_length=70,
        description=(
            "The robot's joints in the order of robots.md, as many as the robot has "
            "(the IWR: [q1 (mm), q2 (mm), q3 (deg), q4 (deg), l1 … l6 (mm)])"
        ),
        examples=[[400.0, 150.0, 90.0, 45.0, 420.0, 420.0, 420.0, 420.0, 420.0, 420.0]],
    ),
]
Coordinate = Annotated[float, Field(ge=-1e7, le=1e7)]
Position = Annotated[list[Coordinate], Field(min_length=3, max_length=3, description="x, y, z in mm (within ±10 km)")]
Component = Annotated[float, Field(ge=-2.0, le=2.0)]
Quaternion = Annotated[
    list[Component],
    Field(min_length=4, max_length=4, description="unit quaternion [w, x, y, z]", examples=[[1, 0, 0, 0]]),
]


class Pose(Strict):
    position: Position
    orientation: Quaternion


class Target(Strict):
    """A pose to reach; without `orientation` only the position counts."""

    position: Position
    orientation: Quaternion | None = None


class PosePublic(Public):
    position: list[float] = Field(description="mm")
    orientation: list[float] = Field(description="unit quaternion [w, x, y, z]")


PARAMETER_UNITS = Literal["mm", "deg", "ppm/K", "µm/N"]
"""Boundary units of parameters: lengths, angles, and the model terms' expansion coefficients and compliances."""


class Payload(Strict):
    """A load carried by the platform (or tool): its mass and centre of gravity in the tool (TCP) frame."""

    mass_kg: float = Field(ge=0, le=10_000, description="kg")
    cog_mm: list[float] = Field(
        default_factory=lambda: [0.0, 0.0, 0.0],
        min_length=3,
        max_length=3,
        description="Centre of gravity [x, y, z] in the tool (TCP) frame, mm",
    )


TemperatureC = Annotated[float, Field(ge=-60, le=200, description="°C")]


def _iso_time(text: str) -> str:
    """An ISO 8601 time, kept as sent (the stored campaign is what was received)."""
    try:
        datetime.fromisoformat(text)
    except ValueError as exc:
        raise ValueError(f"{text!r} is not an ISO 8601 time such as 2026-12-05T14:03:00Z") from exc
    return text


RecordTime = Annotated[
    Annotated[float, Field(ge=-1e12, le=1e12)] | Annotated[str, Field(max_length=64), AfterValidator(_iso_time)],
    Field(description="Seconds from any origin (within ±1e12 s), or an ISO 8601 time"),
]


class RangePublic(Public):
    min: float
    max: float


class ConditionsPublic(Public):
    """What a campaign was measured under: the range a version is calibrated for."""

    temperature_c: RangePublic | None = Field(description="The records' temperatures; null: none given")
    payload_kg: RangePublic | None = Field(description="The payload masses (campaign or records); null: none")
    time: list[str] | None = Field(description="The first and last record's ISO 8601 time; null: no ISO times")
    duration_s: float | None = Field(description="From the first record to the last; null: no time stamps")
    records: int


class ConditionWarningPublic(Public):
    """A condition of a request outside the range its version was calibrated under (the answer is still given)."""

    condition: Literal["temperature_c", "payload_kg"]
    value: float = Field(description="The request's farthest value outside the range")
    calibrated: RangePublic
    outside_by: float = Field(description="How far beyond the range (°C, kg)")
    version: int
    message: str
