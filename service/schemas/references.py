"""Records of the instruments a cell owns (a ballbar or a distance sensor, a socket, a touch probe on a plate)
and the descriptions of the references they measure, as a campaign carries them (boundary units: mm, deg).

A record names its kind (`"kind"`); a record without one is a tracker's (`Record`). The names of anchors,
points and planes become parameter names (`anchor.a1.x`), so they are short identifiers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from service.schemas.common import JointVector, Position, Public, Strict, optional, short_name

ReferenceName = Annotated[
    str, short_name("Letters, digits, _ and - (it names the reference's parameters: anchor.<name>.x)", example="a1")
]
RecordSigma = Annotated[
    float, Field(gt=0, le=100, description="This record's uncertainty (1 σ, mm); default: noise.position_mm")
]

RotationVectorDeg = Annotated[
    list[Annotated[float, Field(ge=-360, le=360)]],
    Field(min_length=3, max_length=3, description="A rotation vector: its axis times its angle, deg"),
]


class CameraDescription(Strict):
    """A calibrated pinhole camera (OpenCV's model): its intrinsics are known, its pose is identified."""

    fx: float = Field(gt=0, le=1e6, description="px")
    fy: float = Field(gt=0, le=1e6, description="px")
    cx: float = Field(ge=-1e5, le=1e5, description="px")
    cy: float = Field(ge=-1e5, le=1e5, description="px")
    distortion: Annotated[list[float], Field(min_length=5, max_length=5)] | None = optional(
        "[k1, k2, p1, p2, k3] as OpenCV gives them; default none"
    )
    width: float | None = Field(default=None, gt=0, le=1e5, description="px; used by pose design")
    height: float | None = Field(default=None, gt=0, le=1e5, description="px; used by pose design")
    mount: Literal["world", "tool"] = Field(
        default="world",
        description="world: fixed in the cell, seeing markers given in the tool frame; tool: on the tool "
        "(hand-eye), seeing points given in the world frame",
    )
    # What pose design needs of a camera that a calibration finds from the records itself: where it is (a
    # candidate image holds only the targets in front of it and on its image) and what it would see.
    position_mm: Position | None = optional(
        "Used by pose design (a calibration finds it from the records): a guess of where the camera "
        "is, mm, in its parent frame: the world for mount world, the tool (TCP) frame for mount tool"
    )
    rotation_vector_deg: RotationVectorDeg | None = optional(
        "Used by pose design: a guess of the camera frame's orientation in its parent frame (camera "
        "frame → parent) as a rotation vector, deg; OpenCV's camera frame: z forward along the line of sight, x "
        "right across the image, y down it. A rough guess is enough"
    )
    targets_mm: list[Position] | None = Field(
        default=None,
        min_length=1,
        max_length=1000,
        description="Used by pose design: the points the camera would see, mm: markers in the tool frame for mount "
        "world, board points in the world frame for mount tool",
    )
    sigma_px: float | None = Field(
        default=None,
        gt=0,
        le=100,
        description="Used by pose design: the σ of its pixel coordinates the predictions are for; default 0.1 px "
        "(a calibration takes each image's sigma_px)",
    )


class AnchorDescription(Strict):
    """An anchor a campaign measures, or a pose design plans records against (a design needs `position_mm`:
    the rows a record adds depend on the direction from the anchor to the TCP)."""

    position_mm: Position | None = optional(
        "A guess of its position (robot base frame, mm); default: found from the records"
    )
    length_unknown: bool = Field(
        default=False, description="The bar's length offset is not known: it is identified (anchor.<name>.length)"
    )
    range_mm: tuple[Annotated[float, Field(ge=0, le=1e5)], Annotated[float, Field(gt=0, le=1e5)]] | None = Field(
        default=None,
        description="Used by pose design: the distances the instrument can read, [min, max] mm (a ballbar reads only "
        "near its length). Sampled candidates are kept against this anchor only where the TCP's distance to "
        "position_mm lies in it; calibrations do not use it",
        examples=[[140.0, 160.0]],
    )

    @model_validator(mode="after")
    def _ordered(self) -> AnchorDescription:
        if self.range_mm is not None and self.range_mm[0] >= self.range_mm[1]:
            raise ValueError(f"range_mm {list(self.range_mm)}: give [min, max] with min < max")
        return self


class PointDescription(Strict):
    """A fixed point (a socket) a campaign measures, or a pose design plans records against (a design does not
    need its position: the rows of a record on it do not depend on where it is)."""

    position_mm: Position | None = optional("A guess; default: found from the records")


class PlaneDescription(Strict):
    """A plane a campaign's touches measure, or a pose design plans touches of (a design needs `normal`: a
    touch's row is the TCP's motion along it; its offset does not enter)."""

    normal: Annotated[list[float], Field(min_length=3, max_length=3)] | None = optional(
        "The side the probe touches from (any length, not zero); default: found from the records, "
        "pointing to +z where it is ambiguous"
    )


class ReflectorDescription(Strict):
    """A reflector on the tool beside the TCP's (a calibration finds its offset from the records; a pose design
    needs a guess of it: its rows turn with the tool by the offset)."""

    offset_mm: Position | None = optional(
        "A guess of where it sits from the TCP, mm, in the TCP frame; default: found from the records"
    )


class DescriptionsBase(Strict):
    """The base of `ReferenceDescriptions` (`service.record_kinds`), which adds one map per record kind whose
    references a body describes: the kinds own their maps."""

    if TYPE_CHECKING:  # the maps are the registry's fields, added where it builds the class

        def __getattr__(self, name: str) -> Any: ...


class CandidateBase(Strict):
    """The base of `ReferenceCandidate` (`service.record_kinds`), which adds the field that names each kind's
    reference: a candidate names exactly one."""

    joints: JointVector

    if TYPE_CHECKING:

        def __getattr__(self, name: str) -> Any: ...

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The fields a candidate may name its reference by, in the registry's order."""
        return tuple(name for name in cls.model_fields if name != "joints")

    @model_validator(mode="after")
    def _one(self) -> CandidateBase:
        kinds = self.names()
        named = [k for k in kinds if getattr(self, k) is not None]
        if len(named) != 1:
            listed = ", ".join(kinds[:-1]) + " or " + kinds[-1]
            raise ValueError(f"a candidate names exactly one of {listed}, not {named or 'none'}")
        return self

    @property
    def reference(self) -> tuple[str, str]:
        """(the field that names its reference: anchor, point, plane, camera, …; the reference's name)."""
        for kind in self.names():
            name = getattr(self, kind)
            if name is not None:
                return kind, str(name)
        raise AssertionError("validated: one is named")


def record_tag(value: Any) -> str:
    """Which record a value is: its `kind`, or a tracker's where it names none (the contract's rule)."""
    kind = value.get("kind", "tracker") if isinstance(value, dict) else getattr(value, "kind", "tracker")
    return str(kind)


class ReferenceUnknownPublic(Public):
    name: str = Field(description="anchor.<name>.x …, point.<name>.x …, plane.<name>.alpha …")
    value: float
    std_error: float | None
    unit: Literal["mm", "deg"]


class ReferencePublicBase(Public):
    """The base of `ReferencePublic` (`service.record_kinds`), which adds its `kind` (the models' kinds of
    reference, from the registry) and the fields each kind reports of its own (`RecordKind.report_fields`)."""

    kind: str
    name: str
    records: int
    rms_residual_mm: float
    unknowns: list[ReferenceUnknownPublic]
    position_mm: list[float] | None = optional("An anchor's or a point's position")

    if TYPE_CHECKING:

        def __getattr__(self, name: str) -> Any: ...
