from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import Field

from service.schemas.common import OptionalFloat, Pose, PosePublic, Public, Strict

MAX_VERSION = 2**31 - 1
"""Parameter versions are 32-bit integers in PostgreSQL (INTEGER); a larger `?version=` is a 422, not a 500."""

PrintableName = Annotated[
    str,
    Field(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$", examples=["cell-3"]),
]
"""No control characters: PostgreSQL text cannot hold NUL, and a name with a newline would forge log lines."""


class RobotCreate(Strict):
    name: PrintableName
    model: Literal["iwr"] = "iwr"
    base: Pose | None = Field(default=None, description="Nominal guess of world <- robot base (default identity)")
    tool: Pose | None = Field(default=None, description="Nominal guess of platform -> TCP (default identity)")


class RobotPublic(Public):
    id: str
    name: str
    model: str
    parameter_version: int
    created_at: datetime
    base: PosePublic
    tool: PosePublic


class ParameterPublic(Public):
    name: str
    value: float = Field(description="mm or deg (see unit)")
    unit: Literal["mm", "deg"]
    nominal: float
    std_error: OptionalFloat = Field(description="Same unit; null until a calibration has estimated it")
    identifiable: bool | None


class ParametersPublic(Public):
    version: int
    provenance: str = Field(description="'nominal' or 'calibration'")
    calibration_id: str | None
    parameters: list[ParameterPublic]
