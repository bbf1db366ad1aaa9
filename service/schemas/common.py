"""Shared request/response pieces; every request model forbids unknown fields and non-finite numbers."""

from __future__ import annotations

from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field


class Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class Public(BaseModel):
    model_config = ConfigDict(extra="allow")


JointValue = Annotated[float, Field(ge=-1e6, le=1e6)]
JointVector = Annotated[
    list[JointValue],
    Field(
        min_length=10,
        max_length=10,
        description="[q1 (mm), q2 (mm), q3 (deg), q4 (deg), l1 … l6 (mm)]",
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
    position: list[float]
    orientation: list[float]


class JobAccepted(Public):
    job_id: str
    status_url: str
