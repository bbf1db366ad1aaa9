"""Program compensation: a robot program in, the same program with its Cartesian targets corrected out."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from service.schemas.common import (
    ConditionWarningPublic,
    JointVector,
    Payload,
    Position,
    Public,
    Quaternion,
    Strict,
    TemperatureC,
    optional,
)

ProgramFormat = Literal["krl", "rapid", "urscript", "csv"]
PROGRAM_CHARS = 20_000_000
"""The body limit (IWR_MAX_BODY_BYTES, 20 MB) is the real bound; the schema says the same of the text."""
BASE_CONVENTION = (
    "Targets are in the controller's frames: the robot base (the calibrated model's base frame: the nominal "
    "geometry is placed where the calibrated model puts the robot's base), through the program's base or work "
    "object and its tool."
)


class PendantReading(Strict):
    """What the controller's pendant displays at some joints: the TCP in the robot-base frame, its active tool."""

    joints: JointVector
    position: Position
    orientation: Quaternion | None = None


class PendantCheckPublic(Public):
    readings: int
    max_position_mm: float = Field(description="Largest |displayed − nominal model| position")
    max_orientation_deg: float | None = optional("Where readings gave orientations")


class ProgramRequest(Strict):
    format: ProgramFormat = Field(description="The program's language: KUKA KRL, ABB RAPID, URScript, CSV of poses")
    program: str = Field(
        max_length=PROGRAM_CHARS,
        description="The program's text (a .src, .dat, .mod, .script or .csv file), line ends kept",
    )
    version: int | None = Field(default=None, ge=1, description="The parameter version (default: the current one)")
    files: dict[str, str] = Field(
        default_factory=dict,
        max_length=32,
        description="Companion files by name: a KRL .dat and $config.dat (BASE_DATA, TOOL_DATA), RAPID modules "
        "with the tooldata and wobjdata; those holding targets come back corrected",
    )
    pendant: list[PendantReading] = Field(
        default_factory=list,
        max_length=50,
        description="A few pendant readings (joints and the displayed pose): the program is compensated only if "
        "the nominal model reproduces them (same convention, tool and units as the controller); otherwise a 422 "
        "says what differs",
    )
    pendant_tolerance_mm: float = Field(default=0.5, gt=0, le=100, description="How closely they must agree")
    seed: JointVector | None = optional(
        "Joints (deg, mm) near which the nominal controller's solution of each target is sought "
        "(default: mid-range), moved into each target's declared configuration (KRL T, RAPID cf1/cf4/cf6)"
    )
    temperature_c: TemperatureC | None = optional(
        "The temperature the program will run at: compared with what the version was calibrated under "
        "(a warning outside it); the targets are corrected by the version's geometry whatever it is"
    )
    payload: Payload | None = optional("The payload the program will carry: compared likewise (a warning outside)")


class CompensatedTarget(Public):
    file: str | None = Field(description="The companion file holding the target (null: the program)")
    line: int
    column: int
    name: str | None = Field(description="The variable holding the target (null: written inside a motion)")
    base_frame: str | None = Field(
        description="The base it is taught in, as the program names it (BASE_DATA[2], a wobjdata, a feature); "
        "null: the robot's base"
    )
    tool_frame: str | None = Field(
        description="The tool it is taught with, as the program names it; null: the robot model's own tool"
    )
    reached: bool = Field(description="Corrected; false: kept as written, `reason` says why")
    correction_mm: list[float] | None = Field(
        description="New minus old position in the target's base frame (mm); null where kept"
    )
    correction_deg: list[float] | None = Field(
        description="The rotation from the old orientation to the new one, as a rotation vector in the target's "
        "base frame (deg); null where kept"
    )
    reason: str | None = None
    branch: str | None = optional(
        "What fixed the joint configuration the target was solved in: the request's seed, the "
        "program's joint move before it, its declared configuration, or (with a warning) the middle of the ranges"
    )
    warning: str | None = optional(
        "Set on a compensated target whose configuration the program does not fix: the robot may run "
        "it on another branch than the one it was compensated for"
    )


class ProgramResponse(Public):
    format: ProgramFormat
    version: int = Field(description="The parameter version the program was compensated for")
    program: str = Field(description="The program, its corrected targets' numbers changed, every other byte kept")
    files: dict[str, str] = Field(description="The companion files that hold corrected targets, rewritten")
    targets: list[CompensatedTarget]
    base: str = Field(default=BASE_CONVENTION, description="How the robot-base frame is defined")
    encoding: str | None = optional(
        "For a program sent as the body itself: the encoding its bytes were read in (utf-8, utf-16, "
        "windows-1252); write the answer's program back in it for the controller"
    )
    controller_frame: str | None = optional(
        "The controller's base frame the targets are read in, by name: the first frame of a DH/MDH "
        "table, an imported URDF's root (or its ROS-Industrial `base` link), UR's Base for a UR kinematics file"
    )
    pendant: PendantCheckPublic | None = optional("How the nominal model reproduced the pendant readings, when given")
    warnings: list[ConditionWarningPublic] = Field(
        default_factory=list,
        description="The stated temperature_c or payload outside what the version was calibrated under",
    )
