from __future__ import annotations

from pydantic import Field, model_validator

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
    absent_if_none,
    optional,
)

TEMPERATURE = (
    "°C: one number, or one per joint vector (target); used where the robot's current version has the thermal "
    "term (default: its reference temperature)"
)
PAYLOAD = "Used where the robot's current version has the compliance term (default: none)"


FRAMES_MAX = 1000
"""Joint vectors a request may ask every frame for: each brings a dozen poses (a drawing's few, not a batch)."""
ACCURACY_MAX = 10_000
"""Joint vectors a request may ask the predicted accuracy for: each needs its pose Jacobian and a search of the
measured poses."""


class ForwardRequest(Strict):
    joints: list[JointVector] = Field(min_length=1, max_length=100_000)
    temperature_c: TemperatureC | list[TemperatureC] | None = optional(TEMPERATURE)
    payload: Payload | None = optional(PAYLOAD)
    frames: bool = Field(
        default=False,
        description=f"Also every frame of the structure (base, each link's middle and end, each platform, the "
        f"TCP: the frames GET …/cell names its shapes by), for at most {FRAMES_MAX} joint vectors",
    )

    accuracy: bool = Field(
        default=False,
        description="Also the current version's predicted 1-σ TCP error at each joint vector, and whether each lies "
        "in the region its calibration measured (outside it: extrapolation, with the reason); needs a calibrated "
        f"version; for at most {ACCURACY_MAX} joint vectors",
    )

    @model_validator(mode="after")
    def _few_frames(self) -> ForwardRequest:
        if self.frames and len(self.joints) > FRAMES_MAX:
            raise ValueError(
                f"frames: every frame is given for at most {FRAMES_MAX} joint vectors, not {len(self.joints)}: "
                "ask for the TCP alone (frames false) or send fewer"
            )
        if self.accuracy and len(self.joints) > ACCURACY_MAX:
            raise ValueError(
                f"accuracy: predicted for at most {ACCURACY_MAX} joint vectors, not {len(self.joints)}: send fewer"
            )
        return self


class PoseAccuracyPublic(Public):
    """The current version's prediction at one joint vector, judged against the region its campaign measured."""

    position_mm: OptionalFloat = Field(
        description="Predicted 1-σ TCP position error (first order, from the calibration's covariance); null "
        "where the platform does not close"
    )
    orientation_deg: OptionalFloat = Field(description="Predicted 1-σ TCP orientation error")
    distance_to_measured: float = Field(
        description="How far the nearest measured pose is: the largest over joints of the difference as a share "
        "of that joint's range (0.1 = 10 % of a range)"
    )
    in_measured_region: bool = Field(
        description="Inside the measured region: the prediction is comparable to the region's figures"
    )
    extrapolation: str | None = Field(
        description="Why the pose is extrapolation (joints outside the measured spans, the nearest measured pose "
        "far away, the prediction far above the region's and the direction of the parameters behind it); null inside"
    )


class MeasuredRegionPublic(Public):
    """What the current version's calibration measured, and its prediction there."""

    calibration_id: str
    version: int
    poses: int = Field(description="Joint vectors of its campaign")
    rms_position_mm: OptionalFloat = Field(description="Predicted 1-σ TCP position error at the measured poses, RMS")
    max_position_mm: OptionalFloat = Field(description="The same, the worst measured pose")
    widest_gap: float = Field(
        description="The largest distance from a measured pose to its nearest measured neighbour (share of a "
        "joint's range): a pose further than twice this from every measured pose is away from the region"
    )


class ForwardResponse(Public):
    poses: list[PosePublic]
    warnings: list[str] = Field(
        default_factory=list,
        description="Slips the joints betray although they lie inside the ranges (revolute joints in radians)",
    )
    frames: list[dict[str, PosePublic]] | None = absent_if_none(
        "With frames: per joint vector, each frame's pose in the world frame by name, base to TCP "
        "(the geometric model's, as the cell's checks use; absent otherwise)",
    )
    accuracy: list[PoseAccuracyPublic] | None = absent_if_none(
        "With accuracy: per joint vector, the predicted error and whether it lies in the measured region"
    )
    measured_region: MeasuredRegionPublic | None = absent_if_none(
        "With accuracy: the calibration whose covariance predicts, and its measured region"
    )


class InverseRequest(Strict):
    targets: list[Target] = Field(min_length=1, max_length=100_000)
    seed: JointVector | None = optional("Joints to stay closest to (default: mid-range)")
    weights: list[float] | None = Field(default=None, min_length=1, max_length=70, description="Per-joint weights")
    follow: bool = Field(default=False, description="Seed each target with the previous answer (smooth paths)")
    temperature_c: TemperatureC | list[TemperatureC] | None = optional(TEMPERATURE)
    payload: Payload | None = optional(PAYLOAD)


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
