from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import Field

from service.schemas.common import JointVector, Position, Public, Quaternion, Strict


class Record(Strict):
    joints: JointVector
    position: Position
    orientation: Quaternion | None = None


class Noise(Strict):
    position_mm: float = Field(default=0.025, gt=0, le=1000)
    orientation_deg: float = Field(default=0.01, gt=0, le=180)


class CalibrationOptions(Strict):
    estimate: list[str] = Field(
        default=["base", "carriage", "hexapod", "tool"], min_length=1, description="Groups or parameter names"
    )
    robust: Literal["none", "huber", "soft_l1"] = "none"
    robust_scale: float = Field(default=3.0, gt=0, le=1000, description="In units of σ")


class CalibrationCreate(Strict):
    measurements: list[Record] = Field(min_length=1, max_length=100_000)
    noise: Noise = Noise()
    apply: bool = True
    options: CalibrationOptions = CalibrationOptions()
    start_version: int | None = Field(
        default=None,
        ge=1,
        le=2**31 - 1,
        description="Parameter version the fit starts from (default: the robot's current one); the parameters "
        "it does not estimate keep this version's values",
    )


class CalibrationPublic(Public):
    id: str
    robot_id: str
    status: str
    reason: str | None
    parameter_version: int | None
    start_version: int | None
    applied: bool
    created_at: datetime
    parameters: list[dict[str, Any]]
    identifiable: list[str]
    unidentifiable: list[str]
    residuals: dict[str, Any]
    solver: dict[str, Any]
