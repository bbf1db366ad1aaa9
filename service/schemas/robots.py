from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from service.schemas.common import OptionalFloat, Pose, PosePublic, Public, Strict


class RobotCreate(Strict):
    name: str = Field(min_length=1, max_length=200, examples=["cell-3"])
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
