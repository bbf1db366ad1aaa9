"""Robots of several chains (issue 47) at the boundary: a tree of branches, each a robots.md chain of stages
hanging from its parent's end frame or from the base, each tip ending in a tool; its kinematics (every tool and
every tool in another's frame) and its calibration from records of any of its tools.

mm and degrees here, as everywhere in the API: a branch's stages are robots.md stage documents (read by the
models' document reader), its mount and tool poses like a structure's base and tool (mm, unit quaternion).
`service/conversions/robot_trees.py` turns a document into `models.tree.RobotTree` and the answers back.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import Field, model_validator

from models.measurement import MeasurementKind
from optimal_design.criteria import Criterion
from service.compute import limits
from service.schemas.common import OptionalFloat, PosePublic, Position, Public, Quaternion, Strict, optional, short_name
from service.schemas.exports import DhLinkPublic, FramePublic
from service.schemas.robots import PrintableName
from service.schemas.structure import Stage, StructurePose

BranchName = Annotated[
    str,
    short_name(
        "Letters, digits, _ and -: it prefixes its parameters (`left.link3.a`) and names its tool", example="left"
    ),
]
JointName = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]+$")]
JointValue = Annotated[float, Field(ge=-1e7, le=1e7, description="deg (revolute) or mm (prismatic)")]
TipLink = Annotated[str, Field(min_length=1, max_length=200)]


class TreeBranchDocument(Strict):
    """One chain of a tree: its stages hang from `parent`'s end frame (or the tree's base), placed by `mount`."""

    name: BranchName
    parent: BranchName | None = optional("The branch it hangs from; null: the tree's base")
    mount: StructurePose | None = optional(
        "parent's end frame (or the base) <- this branch's first frame, mm and unit quaternion; "
        "null: its first link is written in the parent's end frame, as a chain's next link would be"
    )
    stages: list[Stage] = Field(
        default_factory=list,
        max_length=8,
        description="robots.md stages (serial DH/MDH links, a hexapod), as a structure's; empty for a branch "
        "that only places a tool (a fixture on a mount)",
    )
    tool: StructurePose | None = optional(
        "last frame -> this branch's tool (mm, quaternion); a tip of the tree has one"
    )
    joint_names: list[JointName] | None = Field(
        default=None, max_length=limits.TREE_JOINTS_MAX, description="Its joints' names; default `{name}.q1` …"
    )


class RobotTreeCreate(Strict):
    """A tree from branches, or from a URDF with the tip links to keep (its branches found where the paths
    part); one of the two."""

    name: PrintableName
    base: StructurePose | None = optional("world (the instrument) <- the tree's base frame (default identity)")
    branches: list[TreeBranchDocument] | None = Field(
        default=None,
        min_length=1,
        max_length=limits.TREE_BRANCHES_MAX,
        description="Parents before or after their children: the order is found; parameters follow it",
    )
    urdf: str | None = Field(
        default=None,
        max_length=2_000_000,
        description="A URDF (not a xacro: expand it first); the chains from `base_link` to each of `tip_links`",
    )
    base_link: str | None = Field(default=None, max_length=200)
    tip_links: list[TipLink] | None = Field(
        default=None,
        min_length=1,
        max_length=limits.TREE_BRANCHES_MAX,
        description="The URDF's tools (two hands, a torch and a part table): each a link below a moving joint",
    )


class TreeParameterPublic(Public):
    name: str
    group: str = Field(description="base, a branch's name (its mount and links), or `{branch}.tool`")
    unit: Literal["mm", "deg"]
    value: float = Field(description="Current value (calibrated when the tree has been)")
    nominal: float
    std_error: OptionalFloat = Field(description="From the calibration that set it; null when not estimated")


class TreeBranchPublic(Public):
    name: str
    parent: str | None
    children: list[str]
    mount: PosePublic | None
    tool: PosePublic | None
    joint_names: list[str]
    joint_units: list[Literal["mm", "deg"]]
    joint_ranges: list[list[float]] = Field(description="[lo, hi] per joint, deg or mm")
    links: int = Field(description="Its serial links (a hexapod's legs not counted)")
    stages: list[Stage]


class RobotTreePublic(Public):
    id: str
    name: str
    revision: int = Field(description="Bumped by each change (an applied calibration): the ETag")
    created_at: datetime
    source: Literal["document", "urdf"]
    base_link: str | None
    tip_links: list[str] | None
    base: PosePublic
    branches: list[TreeBranchPublic] = Field(description="Parents before their children")
    tools: list[str] = Field(description="The tips' names, in branch order: a record names one")
    joint_names: list[str] = Field(description="The tree's joint vector, branch by branch")
    joint_units: list[Literal["mm", "deg"]]
    parameter_count: int
    groups: dict[str, list[str]] = Field(description="Parameter names by group")
    parameters: list[TreeParameterPublic]
    calibration_id: str | None = Field(description="The calibration whose parameters are current; null: nominal")


TreeJoints = Annotated[
    dict[JointName, JointValue] | Annotated[list[JointValue], Field(min_length=1, max_length=limits.TREE_JOINTS_MAX)],
    Field(
        description="The tree's joints by name ({\"waist.q1\": 10, …}) or as the tree's joint vector in "
        "`joint_names` order; deg for revolute, mm for prismatic joints"
    ),
]


class TreeKinematicsRequest(Strict):
    joints: list[TreeJoints] = Field(min_length=1, max_length=limits.TREE_KINEMATICS_MAX)
    frames: bool = Field(default=True, description="Also every frame of every branch, to draw the tree")


class TreePosePublic(Public):
    position: list[float] = Field(description="mm")
    orientation: list[float] = Field(description="unit quaternion [w, x, y, z]")
    rotation_vector_deg: list[float]


class TreeFramePublic(Public):
    name: str = Field(
        description="`base`, `{branch}.mount`, `{branch}.link{i}.mid`, `{branch}.link{i}`, `{branch}.stage{k}`, "
        "`{tool}.tool`"
    )
    branch: str | None = Field(description="The branch it moves with; null for the base")
    position: list[float] = Field(description="mm, world frame")
    orientation: list[float]


class TreePoseAnswer(Public):
    tools: dict[str, TreePosePublic] = Field(description="Each tool in the world (the instrument's) frame")
    relative: dict[str, TreePosePublic] = Field(description="`a/b`: tool a in tool b's frame, each ordered pair")
    frames: list[TreeFramePublic] | None = optional("With frames: every frame, once")
    chains: dict[str, list[str]] | None = optional("With frames: per tool, its frames' names from the base to the tool")


class TreeKinematicsPublic(Public):
    revision: int = Field(description="The tree's revision whose parameters were used")
    poses: list[TreePoseAnswer]


class TreeRecord(Strict):
    """One measurement of one tool: its position (and orientation) in the instrument's frame, or in another
    tool's frame (`frame`), at the tree's joints."""

    tool: BranchName
    frame: BranchName | None = optional("Measured in this tool's frame; null: the instrument's")
    joints: TreeJoints
    position: Position
    orientation: Quaternion | None = optional("Unit quaternion [w, x, y, z]; null: position only")
    sigma_mm: float | None = Field(default=None, gt=0, le=100, description="This record's σ (default: the request's)")


class TreeCalibrationCreate(Strict):
    records: list[TreeRecord] = Field(min_length=1, max_length=limits.TREE_RECORDS_MAX)
    held_out: list[TreeRecord] = Field(
        default_factory=list,
        max_length=limits.TREE_RECORDS_MAX,
        description="Records not fitted: each tool's (and pair's) error on them after the fit, and before it",
    )
    noise_position_mm: float = Field(default=0.025, gt=0, le=100, description="The instrument's σ (mm)")
    noise_orientation_deg: float = Field(default=0.01, gt=0, le=10)
    apply: bool = Field(default=True, description="Store the result as the tree's parameters (a new revision)")
    accuracy_samples: int = Field(
        default=200, ge=10, le=2000, description="Random joint vectors the predicted accuracy is taken over"
    )

    @model_validator(mode="after")
    def _few(self) -> TreeCalibrationCreate:
        if len(self.records) + len(self.held_out) > limits.TREE_RECORDS_MAX:
            raise ValueError(f"records and held_out: at most {limits.TREE_RECORDS_MAX} in all")
        return self


class TreeAccuracyPublic(Public):
    """A tool's predicted 1-σ error after the fit (or one tool's in another's frame), over random joints."""

    label: str = Field(description="`tool`, or `tool/frame` for the relative accuracy")
    tool: str
    frame: str | None
    rms_position_mm: float
    max_position_mm: float
    rms_orientation_deg: float


class TreeErrorPublic(Public):
    label: str = Field(description="`tool`, or `tool/frame` for records in another tool's frame")
    records: int
    rms_mm: float = Field(description="RMS position error, mm")
    max_mm: float
    before_rms_mm: float | None = optional("Held-out only: at the parameters before the fit (its base registered)")


class TreeCalibrationPublic(Public):
    id: str
    tree_id: str
    created_at: datetime
    actor: str | None
    applied: bool
    revision: int | None = Field(description="The tree's revision it made current; null when not applied")
    start_revision: int
    records: int
    held_out_records: int
    estimated: list[str] = Field(description="Parameters estimated (the identifiable set)")
    unidentifiable: list[str] = Field(description="Parameters held: the records do not determine them")
    seen_by: dict[str, list[str]] = Field(description="Estimated parameter -> the record groups that move it")
    fit: list[TreeErrorPublic] = Field(description="Per record group: the residual after the fit")
    held_out: list[TreeErrorPublic] = Field(description="Per group of held-out records")
    accuracy: list[TreeAccuracyPublic] = Field(
        description="Predicted: each tool, then each pair of tools (the RELATIVE accuracy: one in the other's frame)"
    )
    variance_factor: float = Field(description="σ̂²/σ²: about 1 when the noise is what the request said")
    noise_consistent: bool
    parameters: list[TreeParameterPublic]
    seconds: float


# ---------------------------------------------------------------------------------------------- designs
class TreeMeasured(Strict):
    """A kind of record a design may choose: a tool in the instrument's frame or in another tool's, its position
    or its whole pose."""

    tool: BranchName
    frame: BranchName | None = optional("In this tool's frame; null: the instrument's")
    measurement: Literal["position", "pose"] = "position"
    sigma_mm: float | None = Field(default=None, gt=0, le=100, description="Its position σ (default: the request's)")

    @property
    def kind(self) -> MeasurementKind:
        """What the record measures, as the models name it (its rows, whether it is position only)."""
        return MeasurementKind(self.measurement)

    @classmethod
    def most_rows(cls, measured: list[TreeMeasured] | None) -> int:
        """The rows of the largest record a design may choose (a position's when none is named)."""
        return max((m.kind.rows for m in measured or ()), default=MeasurementKind.POSITION.rows)


class TreeDesignCreate(Strict):
    """Which records of the tree's tools to take: `count` of the candidates (each joint vector offers one record
    of each kind in `measure`), chosen for `criterion` (GET /v1/design-criteria), against random selections."""

    count: int = Field(ge=1, le=limits.TREE_DESIGN_COUNT_MAX, description="Records to choose", examples=[30])
    criterion: Criterion = Field(default=Criterion.D, description="D, A, E, condition or I (the tools' and pairs')")
    measure: list[TreeMeasured] | None = Field(
        default=None,
        min_length=1,
        max_length=limits.TREE_DESIGN_KINDS_MAX,
        description="The records the instruments can take; default: every tool's position in the instrument's frame",
    )
    candidates: list[TreeJoints] | None = Field(
        default=None,
        min_length=1,
        max_length=limits.TREE_DESIGN_CANDIDATES_MAX,
        description="Joint vectors the records may be taken at (by name or in the tree's order; deg, mm); "
        "default: `candidate_count` drawn uniformly inside `joint_ranges`",
    )
    candidate_count: int = Field(default=300, ge=1, le=limits.TREE_DESIGN_CANDIDATES_MAX)
    joint_ranges: dict[JointName, tuple[JointValue, JointValue]] | None = Field(
        default=None,
        description="Sub-ranges [lo, hi] by joint name (deg, mm) the drawn joint vectors stay within; the others: "
        "their range less 5 % at either end",
        examples=[{"positioner.q1": [-30, 30]}],
    )
    seed: int = Field(default=0, ge=0, le=2**31 - 1, description="Of the drawn candidates and the random baseline")
    noise_position_mm: float = Field(default=0.025, gt=0, le=100, description="The instrument's σ (mm)")
    noise_orientation_deg: float = Field(default=0.01, gt=0, le=10)

    def kinds(self) -> int:
        return 1 if self.measure is None else len(self.measure)

    def offered(self, tools: int) -> int:
        """Candidate records: joint vectors × kinds of record (every tool's position by default)."""
        vectors = len(self.candidates) if self.candidates is not None else self.candidate_count
        return vectors * (tools if self.measure is None else len(self.measure))


class TreeDesignedRecord(Public):
    tool: str
    frame: str | None
    measurement: Literal["position", "pose"]
    joints: dict[str, float] = Field(description="The tree's joints by name, deg or mm")


class TreeDesignPublic(Public):
    """The chosen records, what they predict, and the same for random selections of as many records."""

    tree_id: str
    revision: int = Field(description="The tree's revision whose parameters the design was made at")
    criterion: Criterion
    count: int
    records: list[TreeDesignedRecord] = Field(description="The chosen records, in the order the search chose them")
    indices: list[int] = Field(description="Into the candidate records: joint vector × len(measure) + kind")
    value: OptionalFloat = Field(description="The criterion of the chosen records (log det for D, mm for I …)")
    efficiency: OptionalFloat = Field(description="Against the relaxation's certified bound (1: none can do better)")
    metrics: dict[str, OptionalFloat] = Field(description="As a pose design's (predicted_rms_tcp_mm: over the tools)")
    random_baseline: dict[str, OptionalFloat] = Field(
        description="Median of the same metrics over 20 random selections of `count` candidates, `value` included"
    )
    accuracy: list[TreeAccuracyPublic] = Field(
        description="Predicted 1-σ error after calibrating from the chosen records: each tool, then each pair"
    )
    random_accuracy: list[TreeAccuracyPublic] = Field(description="The same for the median random selection")
    identifiable: list[str]
    candidates: int = Field(description="Candidate records weighed")
    seconds: float
    notes: list[str]


# ---------------------------------------------------------------------------------------------- compensation
class TreeTarget(Strict):
    """Where a tool should go: a pose in the world (the instrument's frame) or in another tool's frame (the torch
    in the positioner's part frame), with the program's joints that set the other branches and seed the tool's."""

    tool: BranchName
    frame: BranchName | None = optional("The target is in this tool's frame; null: the world")
    position: Position
    orientation: Quaternion = Field(description="Unit quaternion [w, x, y, z]")
    joints: TreeJoints = Field(
        description="The program's joints: the frame tool's and any branch the tool shares with another tool are "
        "kept; the tool's own are the nominal solution the compensation starts next to"
    )


class TreeCompensationCreate(Strict):
    targets: list[TreeTarget] = Field(min_length=1, max_length=limits.TREE_TARGETS_MAX)


class TreeCompensatedPublic(Public):
    tool: str
    frame: str | None
    reached: bool
    joints: dict[str, float] = Field(
        description="The tree's joints by name (deg, mm): the compensated ones where reached, the program's where not"
    )
    moved: list[str] = Field(description="The joints the compensation chose (the tool's own branches)")
    change: dict[str, float] = Field(description="Compensated minus the program's joints, by moved joint (deg, mm)")
    reason: str | None = Field(description="Why it was left as the program gave it (null where reached)")


class TreeCompensationPublic(Public):
    tree_id: str
    revision: int = Field(description="The tree's revision whose (calibrated) parameters were used")
    calibration_id: str | None = Field(description="The calibration behind them; null: the nominal tree")
    targets: list[TreeCompensatedPublic]
    reached: int


# ---------------------------------------------------------------------------------------------- exports
class TreeFramePose(FramePublic):
    """A transform: x, y, z (mm), then roll, pitch, yaw (deg), R = Rz(yaw)·Ry(pitch)·Rx(roll)."""


class TreeUrdfExportPublic(Public):
    """The calibrated URDF with, beside it, what no joint origin holds."""

    tree_id: str
    revision: int
    base_link: str
    urdf: str = Field(description="The imported URDF, its moving joints' origins calibrated: a drop-in")
    world_from_base_link: TreeFramePose = Field(
        description="world (the instrument's frame the records were in) <- base_link, calibrated"
    )
    tip_to_tcp: dict[str, TreeFramePose] = Field(description="Each tip link -> its calibrated tool (the measured TCP)")
    rotation: str


class TreeDhBranchPublic(Public):
    branch: str
    parent: str | None
    frame: str = Field(description="What `base` maps: the tree's world, or the parent's end frame")
    base: TreeFramePose
    links: list[DhLinkPublic]
    tool: TreeFramePose = Field(description="The last link's frame -> the tool (identity: a branch without tool)")


class TreeDhExportPublic(Public):
    tree_id: str
    revision: int
    pose: str = Field(description="How each table composes")
    link_transforms: dict[str, str]
    rotation: str
    branches: list[TreeDhBranchPublic] = Field(description="Each branch of serial stages, parents first")
    left_out: list[str] = Field(description="Branches without a table (no stage, or a parallel stage)")
