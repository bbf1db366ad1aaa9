from __future__ import annotations

from pydantic import Field

from service.schemas.common import JointVector, PosePublic, Public, Strict, Target


class ForwardRequest(Strict):
    joints: list[JointVector] = Field(min_length=1, max_length=100_000)


class ForwardResponse(Public):
    poses: list[PosePublic]


class InverseRequest(Strict):
    targets: list[Target] = Field(min_length=1, max_length=100_000)
    seed: JointVector | None = Field(default=None, description="Joints to stay closest to (default: mid-range)")
    weights: list[float] | None = Field(default=None, min_length=10, max_length=10, description="Per-joint weights")
    follow: bool = Field(default=False, description="Seed each target with the previous answer (smooth paths)")


class InverseResponse(Public):
    joints: list[list[float | None]]
    position_error_mm: list[float | None]
    orientation_error_deg: list[float | None] | None
    reachable: list[bool]
    reasons: list[str | None]
