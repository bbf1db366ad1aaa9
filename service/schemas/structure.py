"""The description document of shared/spec/robots.md, typed: the body of `POST /v1/robots` (`structure`), the
`structure` of a robot and `GET /v1/robots/{id}/structure`.

The schema holds the document's shape (keys, kinds, list lengths, numbers); the rules between values (a range
with lo < hi, six joints not on one line, a moving joint, one hexapod at most, `beta` only on a link parallel
to the previous one (mdh, or dh with alpha 0 or ±180°: an addition to robots.md), a home inside the workspace
and the strokes) stay in `models.description.structure`, which names the field in its 422 as robots.md does
(`stages[0].strokes`). One set of classes serves requests and responses: a document the service returns is
accepted back as it is.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializerFunctionWrapHandler, model_serializer

from models.description.hexapod import N_LEGS
from models.description.serial_chain import JointType
from models.description.structure import MAX_LINKS
from service.schemas.common import optional, values_of

if TYPE_CHECKING:
    Joint = JointType
else:
    Joint = values_of(JointType)


class Document(BaseModel):
    """Unknown keys refused, numbers finite; keys left out (a fixed link's range, `beta`) stay out of the JSON
    the service writes, as robots.md writes them."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    # No return annotation on purpose: pydantic would publish the annotated type (a bare object) as the
    # serialised schema instead of the fields.
    @model_serializer(mode="wrap")
    def _without_absent(self, handler: SerializerFunctionWrapHandler):  # type: ignore[no-untyped-def]
        dumped: dict[str, Any] = handler(self)
        return {k: v for k, v in dumped.items() if v is not None}


Number = Annotated[float, Field(ge=-1e7, le=1e7, strict=True)]
"""Every number of a document: mm within ±10 km (as every position of the API) or degrees; beyond, squares and
products of the validation overflow instead of naming the field. Strict: `true` or `"1.5"` is a mistake in a
description, not a number (JSON integers are still numbers)."""
Interval = Annotated[list[Number], Field(min_length=2, max_length=2, description="[lo, hi], lo < hi")]
Point = Annotated[list[Number], Field(min_length=3, max_length=3, description="[x, y, z] in mm")]


class StructurePose(Document):
    position: Point
    orientation: Annotated[
        list[Annotated[float, Field(ge=-2.0, le=2.0)]],
        Field(min_length=4, max_length=4, description="unit quaternion [w, x, y, z]"),
    ]


class StructureLink(Document):
    """One link: `dh` A = Rz(θ) Tz(d) Tx(a) Rx(α), `mdh` A = Rx(α) Tx(a) Rz(θ) Tz(d); a revolute joint adds its
    reading to `theta`, a prismatic one to `d`."""

    joint: Joint
    a: Number = Field(default=0.0, description="mm")
    alpha: Number = Field(default=0.0, description="deg")
    d: Number = Field(default=0.0, description="mm")
    theta: Number = Field(default=0.0, description="deg")
    beta: Number | None = optional(
        "deg, Hayati's parameter: only on a link parallel to the previous one "
        "(mdh; or dh with alpha within 5° of 0 or ±180°, an addition to robots.md)"
    )
    range: Interval | None = optional("The joint's reading range (deg revolute, mm prismatic); none for a fixed link")


class SerialStage(Document):
    kind: Literal["serial"]
    convention: Literal["dh", "mdh"]
    links: Annotated[list[StructureLink], Field(min_length=1, max_length=MAX_LINKS)]


class StructureWorkspace(Document):
    """The platform pose's box: mm, and Z-Y-X Euler angles in degrees."""

    x: Interval
    y: Interval
    z: Interval
    rz: Interval
    ry: Interval
    rx: Interval


class HexapodStage(Document):
    kind: Literal["hexapod"]
    base_joints: Annotated[
        list[Point], Field(min_length=N_LEGS, max_length=N_LEGS, description="In the stage's start frame, mm")
    ]
    platform_joints: Annotated[
        list[Point], Field(min_length=N_LEGS, max_length=N_LEGS, description="In the platform frame, mm")
    ]
    strokes: Interval | Annotated[list[Interval], Field(min_length=N_LEGS, max_length=N_LEGS)] = Field(
        description="Leg lengths [lo, hi] in mm, one for all legs or one per leg"
    )
    home: StructurePose = Field(description="A platform pose inside the workspace: the forward kinematics' guess")
    workspace: StructureWorkspace | None = None


Stage = Annotated[SerialStage | HexapodStage, Field(discriminator="kind")]
STAGE_KINDS = ("serial", "hexapod")
"""The tags of `Stage`: pydantic puts the chosen one in an error's location, which robots.md's field names omit."""


class StructureDocument(Document):
    """A robot as a chain of stages from its base to its tool, in mm and degrees: serial links (DH or MDH) and at
    most one hexapod, between an optional base and tool."""

    base: StructurePose | None = optional("world <- robot base (default identity)")
    tool: StructurePose | None = optional("last frame -> TCP (default identity)")
    stages: Annotated[list[Stage], Field(min_length=1)]
