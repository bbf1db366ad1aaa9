from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from service.schemas.common import JointVector, Public, Strict


class PoseDesignCreate(Strict):
    count: int = Field(ge=1, le=10_000, description="K, the number of poses to measure", examples=[30])
    criterion: Literal["condition", "D", "A", "E", "I"] = "D"
    measurement: Literal["pose", "position"] = "pose"
    candidates: list[JointVector] | None = Field(default=None, max_length=100_000)
    candidate_count: int = Field(default=2000, ge=1, le=100_000)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    fixed: list[JointVector] | None = Field(default=None, max_length=10_000, description="Poses already measured")


class PoseDesignPublic(Public):
    id: str
    robot_id: str
    poses: list[list[float]]
    indices: list[int] | None
    metrics: dict[str, float | None]
    random_baseline: dict[str, float | None]
    bound: dict[str, Any] | None
