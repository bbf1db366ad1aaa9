from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import Field

from service.schemas.common import (
    PARAMETER_UNITS,
    STRICT_BY_ALIAS,
    FreeText,
    OptionalFloat,
    Pose,
    PosePublic,
    Public,
    Strict,
    optional,
)
from service.schemas.structure import StructureDocument

MAX_VERSION = 2**31 - 1
"""Parameter versions are 32-bit integers in PostgreSQL (INTEGER); a larger `?version=` is a 422, not a 500."""

PrintableName = Annotated[
    str,
    Field(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$", examples=["cell-3"]),
]
"""No control characters: PostgreSQL text cannot hold NUL, and a name with a newline would forge log lines."""


class RobotImport(Strict):
    """A robot's description in a vendor's format: `ur-calibration`, UR's kinematics file (`calibration.yaml` of
    ur_calibration, `default_kinematics.yaml` of ur_description) as its text."""

    format: Literal["ur-calibration"]
    document: str = Field(max_length=64_000, description="The file's text (YAML: `kinematics:` with six joints)")


class RobotCreate(Strict):
    model_config = STRICT_BY_ALIAS

    name: PrintableName
    model: Literal["iwr", "custom"] = Field(
        default="iwr", description="'iwr' (built in), or 'custom' with `structure`, `urdf` or `import`"
    )
    structure: StructureDocument | None = optional(
        "The robot's description document (the StructureDocument schema: base, stages, tool; then "
        "`model` reads 'custom'). A `dh` link whose alpha is 0 or ±180° may carry Hayati's `beta` (deg) as `mdh` "
        "links do, then A_i = Rz(θ)·Tz(d)·Tx(a)·Rx(α)·Ry(β)"
    )
    urdf: str | None = Field(
        default=None, max_length=2_000_000, description="A URDF; the chain from `base_link` to `tip_link` is the robot"
    )
    base_link: str | None = Field(default=None, max_length=200)
    tip_link: str | None = Field(default=None, max_length=200)
    import_: RobotImport | None = Field(
        default=None,
        alias="import",
        description="A 6R arm from a UR's kinematics file, its nominal the file's (factory) calibration; the "
        "chain runs from the controller's base frame to tool0, as ur_description builds it",
    )
    base: Pose | None = optional(
        "Nominal guess of world <- robot base (default identity). With a URDF or an import it is "
        "world <- base_link and composes with the URDF's own base_link <- first joint"
    )
    tool: Pose | None = optional(
        "Nominal guess of platform -> TCP (default identity). With a URDF or an import it is "
        "tip_link -> TCP and composes after the URDF's own last joint -> tip_link"
    )


class RobotPatch(Strict):
    """Only the fields given change. New base or tool guesses make a new parameter version (provenance `edit`)
    with those six values set to the guess and the rest kept from the current version."""

    name: PrintableName | None = None  # POST's rule: a NUL or a newline got past PATCH (issue 31)
    base: Pose | None = optional(
        "New nominal guess of world <- robot base (a URDF robot's: world <- base_link, as at creation)"
    )
    tool: Pose | None = optional(
        "New nominal guess of platform -> TCP (a URDF robot's: tip_link -> TCP, as at creation)"
    )
    notes: FreeText | None = optional('Free text; "" clears it')


class StructureBuildPublic(Public):
    """The state of the robot's structure's native code in this server (service.compute.builds)."""

    state: Literal["building", "ready", "failed"] = Field(
        description="building: started when the robot was created; a request meanwhile waits for it (slower "
        "once, never refused for it). ready: every later request runs on the built code. failed: see detail "
        "(requests still work, on CasADi's virtual machine)"
    )
    started_at: datetime | None = Field(description="null for a structure the server built at start-up")
    seconds: OptionalFloat = Field(description="Wall time of the build; null while building")
    native: bool | None = Field(
        description="true: compiled to native code; false: runs on CasADi's virtual machine, 5-10x slower (no C "
        "compiler where the server runs and no prebuilt library: see detail); null while building"
    )
    detail: str | None = None


class RobotPublic(Public):
    id: str
    name: str
    model: str
    parameter_version: int
    created_at: datetime
    base: PosePublic
    tool: PosePublic
    notes: str | None = None
    revision: int = Field(description="Bumped by every change of the robot or its current version; the ETag")
    structure: StructureDocument = Field(description="The robot's description document (StructureDocument)")
    joint_names: list[str] = Field(description="The joint vector's order: q1 … q_m, then l1 … l6 for a hexapod")
    joint_units: list[Literal["mm", "deg"]]
    parameter_count: int
    build: StructureBuildPublic | None = optional(
        "The structure's build in this server, started when the robot is created (or first read "
        "after a restart); on a single robot's responses (create, read, update), null in lists"
    )


class ParameterPublic(Public):
    name: str
    value: float = Field(description="mm or deg (see unit)")
    unit: PARAMETER_UNITS
    nominal: float
    std_error: OptionalFloat = Field(description="Same unit; null until a calibration has estimated it")
    identifiable: bool | None


class ParametersPublic(Public):
    version: int
    provenance: str = Field(description="'nominal' or 'calibration'")
    calibration_id: str | None
    parameters: list[ParameterPublic]
