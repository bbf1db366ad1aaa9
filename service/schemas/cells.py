"""A robot's cell (issue 46) at the boundary: the fixed obstacles, the instruments, the links' geometry overrides
and the clearance, in mm and degrees; its stored versions; the check of a list of poses against it.

The service turns a document into `models.cell.Cell` (`service/conversions/cells.py`): positions stay mm,
angles become radians. Sizes are positive and finite (a 422 naming the field); the counts that cost the checks
time (obstacles, mesh triangles, a link's shapes, poses to check) are bounded in `service.compute.limits`.
"""

from __future__ import annotations

from datetime import datetime
from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import Field, model_validator

from models.cell import Reason
from service.compute import limits
from service.schemas.common import JointVector, Position, Public, Strict, exactly_one, optional, short_name
from service.schemas.references import RotationVectorDeg

Size = Annotated[float, Field(gt=0, le=1e5, description="mm, positive (up to 100 m)")]
Distance = Annotated[float, Field(ge=0, le=1e6, description="mm")]
SolidName = Annotated[
    str,
    short_name(
        "Letters, digits, _, . and -; refusals name the solid they hit", example="table", pattern=r"^[A-Za-z0-9_.-]+$"
    ),
]
Direction = Annotated[
    list[Annotated[float, Field(ge=-1e3, le=1e3)]],
    Field(min_length=3, max_length=3, description="A direction in the TCP frame (any length but zero)"),
]
Face = Annotated[
    list[Annotated[int, Field(ge=0, le=limits.CELL_MESH_FACES_MAX * 3)]],
    Field(min_length=3, max_length=3, description="Three indices into vertices_mm"),
]
ZERO3: list[float] = [0.0, 0.0, 0.0]


class Placed(Strict):
    """Where a solid's own frame sits in its parent frame (the world for an obstacle, a link frame for a link's
    shape): its centre, and its orientation as a rotation vector."""

    position_mm: Position = Field(default_factory=lambda: list(ZERO3))
    rotation_vector_deg: RotationVectorDeg = Field(default_factory=lambda: list(ZERO3))


class BoxShape(Placed):
    """A box centred on its frame, edges along its axes."""

    kind: Literal["box"]
    size_mm: Annotated[list[Size], Field(min_length=3, max_length=3, description="Full sizes along x, y, z (mm)")]


class CylinderShape(Placed):
    """A cylinder centred on its frame, its axis along z."""

    kind: Literal["cylinder"]
    radius_mm: Size
    length_mm: Size


class SphereShape(Placed):
    kind: Literal["sphere"]
    radius_mm: Size


class CapsuleShape(Placed):
    """The points within radius_mm of a segment of length_mm along z, centred on its frame."""

    kind: Literal["capsule"]
    radius_mm: Size
    length_mm: Distance = 0.0


class MeshShape(Placed):
    """A triangle mesh (a fixture's envelope): vertices in its own frame and triangles of vertex indices."""

    kind: Literal["mesh"]
    vertices_mm: list[Position] = Field(min_length=3, max_length=limits.CELL_MESH_FACES_MAX)
    faces: list[Face] = Field(min_length=1, max_length=limits.CELL_MESH_FACES_MAX)

    @model_validator(mode="after")
    def _indices(self) -> MeshShape:
        n = len(self.vertices_mm)
        bad = next((k for k, f in enumerate(self.faces) if max(f) >= n), None)
        if bad is not None:
            raise ValueError(f"faces[{bad}] names a vertex past the {n} of vertices_mm (indices from 0)")
        return self


class BoxObstacle(BoxShape):
    name: SolidName


class CylinderObstacle(CylinderShape):
    name: SolidName


class SphereObstacle(SphereShape):
    name: SolidName


class CapsuleObstacle(CapsuleShape):
    name: SolidName


class MeshObstacle(MeshShape):
    name: SolidName


ObstacleDocument = Annotated[
    BoxObstacle | CylinderObstacle | SphereObstacle | CapsuleObstacle | MeshObstacle, Field(discriminator="kind")
]
LinkSolid = Annotated[BoxShape | CylinderShape | SphereShape | CapsuleShape, Field(discriminator="kind")]


def _ordered(lo: str, hi: str, instrument: str) -> Any:
    """The model validator of an instrument's reach: its field `lo` below its field `hi`."""

    def check(document: Any) -> Any:
        low, high = getattr(document, lo), getattr(document, hi)
        if not low < high:
            raise ValueError(f"{instrument} {lo}, {hi}: the minimum ({low:g}) must be below the maximum ({high:g})")
        return document

    return model_validator(mode="after")(check)


class TargetDocument(Strict):
    """Where the measured point sits on the tool, in the TCP frame, and which way it faces."""

    offset_mm: Position = Field(default_factory=lambda: list(ZERO3))
    facing: Direction = Field(default_factory=lambda: [0.0, 0.0, 1.0])

    @model_validator(mode="after")
    def _facing(self) -> TargetDocument:
        if not any(self.facing):
            raise ValueError("facing: a direction, not the zero vector")
        return self


class TrackerDocument(Strict):
    """A laser tracker: a pose is seen if the reflector is within range, faces the tracker within its acceptance
    cone, and the beam passes beam_clearance_mm clear of every link and obstacle."""

    position_mm: Position
    range_min_mm: Distance = 1000.0
    range_max_mm: Distance = 20000.0
    acceptance_deg: float = Field(default=30.0, gt=0, le=180, description="The reflector's cone half-angle")
    reflector: TargetDocument = Field(default_factory=TargetDocument)
    beam_clearance_mm: Size = 5.0

    _range = _ordered("range_min_mm", "range_max_mm", "tracker")


class CameraDocument(Placed):
    """A camera looking along its z (x to the image's right) from its pose in the world frame: a pose is seen if
    the target is within the field of view and depth range, faces it within acceptance_deg, and the sight line
    is clear."""

    half_width_deg: float = Field(default=30.0, gt=0, lt=90)
    half_height_deg: float = Field(default=22.5, gt=0, lt=90)
    range_min_mm: Distance = 300.0
    range_max_mm: Distance = 5000.0
    acceptance_deg: float = Field(default=60.0, gt=0, le=180)
    target: TargetDocument = Field(default_factory=TargetDocument)
    sight_clearance_mm: Size = 5.0

    _range = _ordered("range_min_mm", "range_max_mm", "camera")


class BallbarDocument(Strict):
    """A ballbar from a fixed pivot to the TCP (plus tcp_offset_mm): its length must stay within its travel."""

    pivot_mm: Position
    length_min_mm: Distance
    length_max_mm: Distance
    tcp_offset_mm: Position = Field(default_factory=lambda: list(ZERO3))

    _travel = _ordered("length_min_mm", "length_max_mm", "ballbar")


class LinkOverride(Strict):
    """One body's geometry instead of its default: the radius of its capsules, or shapes of its own (each in a
    frame of the body, its end frame by default)."""

    capsule_radius_mm: Size | None = None
    shapes: list[LinkSolid] | None = Field(default=None, min_length=1, max_length=limits.CELL_LINK_SHAPES_MAX)
    frame: str | None = Field(
        default=None,
        max_length=64,
        description="With shapes: the frame they are given in (GET …/cell lists them); default: the body's end frame",
    )

    _one = exactly_one("capsule_radius_mm", "shapes", "give capsule_radius_mm or shapes, one of them")


class CellDocument(Strict):
    """The cell a robot works in, as its plant describes it (world frame of the robot's description: the frame
    its base pose is given in)."""

    obstacles: list[ObstacleDocument] = Field(default_factory=list, max_length=limits.CELL_OBSTACLES_MAX)
    tracker: TrackerDocument | None = None
    camera: CameraDocument | None = None
    ballbar: BallbarDocument | None = None
    links: dict[Annotated[str, Field(max_length=64)], LinkOverride] = Field(
        default_factory=dict,
        max_length=100,
        description="By body (base, link1…, stage2…, tool): its geometry instead of the default GET …/cell shows",
    )
    clearance_mm: float = Field(
        default=10.0, ge=0, le=1000, description="Least distance between two solids that may not touch"
    )
    allowed: list[Annotated[list[SolidName], Field(min_length=2, max_length=2)]] = Field(
        default_factory=list,
        max_length=1000,
        description="More pairs of solids (bodies or obstacles) that may touch, beyond the defaults GET …/cell shows",
    )

    @model_validator(mode="after")
    def _mesh_total(self) -> CellDocument:
        faces = sum(len(o.faces) for o in self.obstacles if isinstance(o, MeshObstacle))
        if faces > limits.CELL_MESH_FACES_MAX:
            raise ValueError(
                f"obstacles: the meshes hold {faces} triangles in all, over the limit of "
                f"{limits.CELL_MESH_FACES_MAX}: simplify them (a fixture's envelope needs hundreds)"
            )
        return self


class CellShapePublic(Public):
    """One shape of the robot's effective geometry: a capsule between two frames' origins (the defaults from the
    link lengths, `segment`), or a solid rigid in one frame (a URDF's or an override's)."""

    body: str
    origin: Literal["default", "urdf", "override"]
    kind: Literal["capsule", "box", "cylinder", "sphere", "mesh"]
    radius_mm: float | None = None
    from_frame: str | None = optional("A segment's start (its capsule runs between frames)")
    to_frame: str | None = None
    from_point_mm: list[float] | None = optional(
        "Where a segment starts in from_frame (a hexapod leg's base joint; else its origin)"
    )
    to_point_mm: list[float] | None = optional("Where a segment ends in to_frame")
    frame: str | None = optional("The frame a rigid solid is given in")
    size_mm: list[float] | None = None
    length_mm: float | None = None
    position_mm: list[float] | None = None
    rotation_vector_deg: list[float] | None = None


class AllowedPairPublic(Public):
    solids: list[str] = Field(description="Two bodies or obstacles that may touch")
    why: str = Field(
        description="adjacent (along the chain), across a prismatic joint, always touching (within the clearance "
        "at every pose tried: a base on its table), or given (the document's `allowed`)"
    )


class CellPublic(Public):
    """A version of the robot's cell: the document as stored and what the checks use with it."""

    robot_id: str
    version: int
    created_at: datetime
    actor: str | None
    cell: CellDocument
    geometry_source: Literal["links", "urdf"] = Field(
        description="links: capsules from the link lengths; urdf: the URDF's collision shapes"
    )
    geometry: list[CellShapePublic] = Field(description="The robot's effective shapes, overrides applied")
    frames: list[str] = Field(description="The frames link shapes may be given in, base to TCP")
    skipped: list[str] = Field(description="What a URDF has that is not modelled (its meshes), by link")
    allowed: list[AllowedPairPublic]


class CellVersionPublic(Public):
    version: int
    created_at: datetime
    actor: str | None
    ended: bool = Field(description="This version ended the cell (DELETE): designs have none after it")
    obstacles: int
    instruments: list[Literal["tracker", "camera", "ballbar"]]


if TYPE_CHECKING:
    ReasonName = str
else:
    ReasonName = Literal[tuple(r.value for r in Reason)]  # the models' reasons, published as an enum


class CellCheckCreate(Strict):
    poses: list[JointVector] = Field(min_length=1, max_length=limits.CELL_CHECK_POSES_MAX)
    cell: Literal["stored"] | CellDocument = Field(
        default="stored", description="stored: the robot's current cell; or a cell document to try"
    )


class PoseVerdictPublic(Public):
    feasible: bool
    reason: ReasonName | None = Field(description="The first test it fails, in the order the checks run")
    detail: str | None = Field(description="What failed: the solids and their distance, the angle, the range")


class CellCheckPublic(Public):
    cell_version: int | None = Field(description="The stored version checked against; null for a document sent")
    feasible: int
    refused: dict[str, int] = Field(description="Refused poses by reason")
    poses: list[PoseVerdictPublic]


class DesignCellPublic(Public):
    """What a pose design's cell refused."""

    version: int | None = Field(description="The stored cell version used; null for a cell sent with the request")
    checked: int = Field(description="Candidates the cell checked (those the joint ranges and keep-out box passed)")
    feasible: int = Field(description="Of them, those it can measure: the design chose among these")
    refused: dict[str, int] = Field(description="Refused candidates by reason")
