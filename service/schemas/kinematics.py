from __future__ import annotations

from pydantic import Field

from service.schemas.common import (
    ConditionWarningPublic,
    JointVector,
    OptionalFloat,
    Payload,
    PosePublic,
    Public,
    Strict,
    Target,
    TemperatureC,
)

TEMPERATURE = (
    "°C: one number, or one per joint vector (target); used where the robot's current version has the thermal "
    "term (default: its reference temperature)"
)
PAYLOAD = "Used where the robot's current version has the compliance term (default: none)"


class ForwardRequest(Strict):
    joints: list[JointVector] = Field(min_length=1, max_length=100_000)
    temperature_c: TemperatureC | list[TemperatureC] | None = Field(default=None, description=TEMPERATURE)
    payload: Payload | None = Field(default=None, description=PAYLOAD)


class ForwardResponse(Public):
    poses: list[PosePublic]
    warnings: list[str] = Field(
        default_factory=list,
        description="Slips the joints betray although they lie inside the ranges (revolute joints in radians)",
    )


class InverseRequest(Strict):
    targets: list[Target] = Field(min_length=1, max_length=100_000)
    seed: JointVector | None = Field(default=None, description="Joints to stay closest to (default: mid-range)")
    weights: list[float] | None = Field(default=None, min_length=1, max_length=70, description="Per-joint weights")
    follow: bool = Field(default=False, description="Seed each target with the previous answer (smooth paths)")
    temperature_c: TemperatureC | list[TemperatureC] | None = Field(default=None, description=TEMPERATURE)
    payload: Payload | None = Field(default=None, description=PAYLOAD)


class ReachedPosePublic(Public):
    """Where the returned joints put the TCP on the calibrated model (null for an invalid target)."""

    position: list[OptionalFloat]
    orientation: list[OptionalFloat]


class InverseResponse(Public):
    joints: list[list[OptionalFloat]] = Field(description="Per target, mm and deg; null for an invalid target")
    position_error_mm: list[OptionalFloat]
    orientation_error_deg: list[OptionalFloat] | None = Field(description="null for position-only targets")
    reachable: list[bool]
    reasons: list[str | None] = Field(description="Why a target is not reached exactly (joints at their limits)")
    reached_poses: list[ReachedPosePublic]
    hexapod_condition: list[OptionalFloat] = Field(description="Condition number of eq. 48 at each answer")
    methods: list[str] = Field(description="'newton', 'ipopt', 'ipopt-nearest' or 'invalid', per target")
    seconds: float
    warnings: list[ConditionWarningPublic] = Field(
        default_factory=list,
        description="The request's temperature_c or payload outside what the current version was calibrated "
        "under (the joints are computed all the same)",
    )
