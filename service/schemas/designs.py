"""Pose-design requests and the complete design report (boundary units: mm, degrees)."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import datetime
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import AfterValidator, Field, model_validator

from models.measurement import MeasurementKind
from optimal_design.criteria import Criterion
from optimal_design.design import MAX_CANDIDATES
from service.record_kinds import (
    RECORD_KINDS,
    REFERENCE_KINDS,
    ReferenceCandidate,
    ReferenceDescriptions,
    described,
)
from service.schemas.calibrations import Noise
from service.schemas.cells import CellDocument, DesignCellPublic
from service.schemas.common import (
    JointVector,
    OptionalFloat,
    Payload,
    Position,
    Public,
    Strict,
    TemperatureC,
    exactly_one,
    optional,
)

MAX_FIXED = 10_000
BOUND_SECONDS_MAX = 60.0
"""Branch and bound past a minute buys little here (K = 30 of 2 000, D: 0.9851 at 3 s, 0.9878 at 20 s)."""


ReferenceMeasurement = str
REFERENCE_MEASUREMENTS: tuple[ReferenceMeasurement, ...] = REFERENCE_KINDS
"""The records of the instruments a cell owns that a design can plan (the record kinds': service.record_kinds)."""


def _either(names: Sequence[str], last: str = "or") -> str:
    """Names as the descriptions list them: "a, b or c"."""
    return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} {last} {names[-1]}"


_PLANNED = [RECORD_KINDS[name] for name in REFERENCE_KINDS]
_WHOLE = [m.value for kind in RECORD_KINDS.values() for m in kind.measurement_kinds]
_WHOLE_KINDS = _either([name for name, kind in RECORD_KINDS.items() if kind.whole_campaign])
_MAPS = [str(kind.described_in) for kind in _PLANNED]
_NAMED_BY = [str(kind.named_by) for kind in _PLANNED]
_SAMPLED = [kind.name for kind in _PLANNED if kind.sampled]
MEASUREMENT_DOC = (
    f"{_either(_WHOLE)}: a {_WHOLE_KINDS}'s records; {_either(list(REFERENCE_KINDS))}: records against the "
    f"{_either(_MAPS)} the body describes (the kind of bare joint vectors among the candidates; sampled ones: "
    f"{_either(_SAMPLED, 'and')} only)"
)
"""The design's `measurement` in the contract, from the registry (`service.record_kinds`)."""
_OTHERS = ", ".join(f'"{name}"' for name in _NAMED_BY[1:])
CANDIDATES_DOC = (
    "Joint vectors; against references, each may name the one its record measures: "
    f'{{"joints": [...], "{_NAMED_BY[0]}": "a1"}} (or {_OTHERS}), which a design of several references needs'
)
FIXED_DOC = (
    "Poses already measured; against references, as candidates: each names the reference its record measured "
    f'({{"joints": [...], "{_NAMED_BY[0]}": "a1"}}), which the design completes'
)
MEASURED_DOC = f"Against references: the {_either(_NAMED_BY)} each chosen pose's record measures"


def _kind(value: str) -> MeasurementKind | str:
    """A tracker's kind as the enum the design pipeline takes; a reference kind as its name."""
    return value if value in REFERENCE_MEASUREMENTS else MeasurementKind(value)


if TYPE_CHECKING:
    DesignMeasurement = MeasurementKind | ReferenceMeasurement
else:
    # The tracker's kinds first, as the contract published them, then the reference kinds it gained.
    DesignMeasurement = Annotated[
        Literal[(*(k.value for k in MeasurementKind), *REFERENCE_MEASUREMENTS)], AfterValidator(_kind)
    ]
DesignCandidate = JointVector | ReferenceCandidate


class DesignTarget(Strict):
    """The accuracy to reach: the predicted TCP position error after calibration, RMS or worst over the
    workspace (give one)."""

    rms_tcp_mm: float | None = Field(default=None, gt=0, le=1000, examples=[0.05])
    max_tcp_mm: float | None = Field(default=None, gt=0, le=1000)

    _one = exactly_one("rms_tcp_mm", "max_tcp_mm", "give exactly one of rms_tcp_mm and max_tcp_mm")


class KeepOutBox(Strict):
    """A box in the world frame (after a calibration: the instrument's) that the TCP and the hexapod's
    platform centre must stay outside, e.g. a fixture or the tracker itself."""

    lower: Position
    upper: Position


class PoseDesignCreate(ReferenceDescriptions):
    count: int | None = Field(
        default=None, ge=1, le=10_000, description="K, the number of poses to measure (or give `target`)", examples=[30]
    )
    target: DesignTarget | None = optional(
        "Instead of count: the smallest K whose design reaches this predicted accuracy"
    )
    criterion: Criterion = Field(default=Criterion.D, description="With a target: D or I (default there: I)")
    measurement: DesignMeasurement = Field(
        default=MeasurementKind.POSE,
        description=MEASUREMENT_DOC,
    )
    candidates: list[DesignCandidate] | None = Field(
        default=None,
        max_length=MAX_CANDIDATES,
        description=CANDIDATES_DOC,
    )
    noise: Noise | None = optional(
        "The instrument's σ the predicted errors are for (a ballbar's is a few µm); default: "
        "position 0.025 mm, orientation 0.01°"
    )
    candidate_count: int = Field(default=2000, ge=1, le=MAX_CANDIDATES)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    fixed: list[DesignCandidate] | None = Field(default=None, max_length=MAX_FIXED, description=FIXED_DOC)
    joint_ranges: dict[str, tuple[float, float]] | None = Field(
        default=None,
        description="Sub-ranges by joint name (q1…, l1…; mm or deg) the candidates must stay within",
        examples=[{"q1": [100, 700]}],
    )
    keep_out: KeepOutBox | None = None
    min_spread: float | None = Field(
        default=None,
        ge=0,
        le=1,
        description="Minimum distance between chosen poses (and from `fixed`): RMS over joints of the difference "
        "divided by each joint's range",
    )
    d_efficiency_floor: float | None = Field(
        default=None,
        ge=0,
        le=1,
        description="E and condition only: optimise over designs whose D-efficiency stays at least this. "
        "Omitted: 0.9 for condition (lowered to what the D design reaches if that is less; the plain condition "
        "design calibrates the TCP little better than random poses), none for E; 0: no floor",
    )
    bound_seconds: float = Field(
        default=0,
        ge=0,
        le=BOUND_SECONDS_MAX,
        description="D, A and I with count: spend up to this long tightening the certificate by branch and bound "
        "(the design can only improve, its efficiency only rise). K = 30 of 2 000, D: 0.980 without, 0.985 after "
        "2-3 s. Counted in the request's work: beyond the synchronous budget, send it with ?async=true",
    )
    terms: list[Literal["thermal", "compliance"]] = Field(
        default_factory=list,
        max_length=2,
        description="Design for a calibration with these model terms (their parameters' columns in the information)",
    )
    temperature_levels_c: list[TemperatureC] | None = Field(
        default=None,
        min_length=1,
        max_length=20,
        description="With terms: the temperatures the cell can be measured at; each candidate is offered at each "
        "(times each payload level), so the design spreads them",
    )
    payload_levels: list[Payload] | None = Field(
        default=None, min_length=1, max_length=20, description="With terms: the payloads the user can mount"
    )
    cell: Literal["stored"] | CellDocument | None = optional(
        "Design only among the poses a cell can measure (collision-free, seen by its instrument): "
        "stored (the robot's current cell, PUT …/cell) or a cell document; absent: no cell. Tracker "
        "measurements only"
    )
    prior: Literal["none", "fleet"] = Field(
        default="none",
        description="fleet: design for a calibration with the robot's fleet's prior (its information joins the "
        "fixed poses'), so a target counts the poses that calibration needs; 422 fleet-too-small while the fleet "
        "has too few calibrated units; tracker measurements only",
    )

    @model_validator(mode="after")
    def _count_or_target(self) -> PoseDesignCreate:
        if (self.count is None) == (self.target is None):
            raise ValueError("give either count (how many poses) or target (what accuracy), not both")
        if self.target is not None and self.bound_seconds > 0:
            raise ValueError("bound_seconds applies to a design of count poses, not to a target")
        if self.target is not None and "criterion" not in self.model_fields_set:
            self.criterion = Criterion.I  # the criterion that minimises the predicted RMS TCP error
        if isinstance(self.measurement, MeasurementKind) and (any(described(self).maps.values()) or any(self._tied())):
            raise ValueError(
                f"measurement {self.measurement.value!r} is a {_WHOLE_KINDS}'s: {', '.join(_MAPS)} and candidates "
                f"that name one belong to measurement {', '.join(REFERENCE_KINDS)}"
            )
        return self

    def _tied(self) -> list[ReferenceCandidate]:
        return [c for c in [*(self.candidates or []), *(self.fixed or [])] if isinstance(c, ReferenceCandidate)]

    def joint_candidates(self) -> list[list[float]] | None:
        """The candidates of a tracker's design: bare joint vectors (the validator refuses the others there)."""
        return _bare(self.candidates)

    def joint_fixed(self) -> list[list[float]] | None:
        """The poses a tracker already measured: bare joint vectors (the validator refuses the others there)."""
        return _bare(self.fixed)

    def offered(self) -> int:
        """How many candidates the design weighs (the request's cost): those given, or those sampled, each
        offered against every anchor and camera in a distance or image design."""
        if self.candidates is not None:
            return len(self.candidates)
        kind = RECORD_KINDS.get(str(self.measurement))
        if kind is not None and kind.sampled:  # each sampled pose offered against each of its references
            return self.candidate_count * max(1, len(kind.descriptions(described(self))))
        return self.candidate_count


def _bare(poses: list[DesignCandidate] | None) -> list[list[float]] | None:
    if poses is None:
        return None
    return [c for c in poses if not isinstance(c, ReferenceCandidate)]


class DesignMetricsPublic(Public):
    """Of the identification problem the poses would give (identifiable parameters, scaled as it scales them).

    Null where the information matrix is singular (an infinite condition number or trace)."""

    condition_number: OptionalFloat
    log_det: OptionalFloat
    min_singular_value: OptionalFloat
    max_singular_value: OptionalFloat
    trace_inverse: OptionalFloat
    predicted_rms_tcp_mm: OptionalFloat
    predicted_max_tcp_mm: OptionalFloat = Field(description="At the worst workspace pose")
    O1: OptionalFloat = Field(description="Borm & Menq: (σ₁⋯σₚ)^(1/P)/√m")
    O2: OptionalFloat = Field(description="σ_min/σ_max")
    O3: OptionalFloat = Field(description="σ_min")
    O4: OptionalFloat = Field(description="Nahvi & Hollerbach: σ_min²/σ_max")
    O5: OptionalFloat = Field(description="Sun & Hollerbach: 1/Σ(1/σᵢ)")
    parameters: OptionalFloat = Field(description="Number of identifiable parameters")


class GreedyPublic(Public):
    """The second baseline: greedy selection improved by exchange."""

    value: OptionalFloat
    efficiency: OptionalFloat
    swaps: int
    seconds: float


class BranchAndBoundPublic(Public):
    """How far `bound_seconds` of branch and bound tightened the relaxation's bound."""

    seconds: float
    root_utility: float = Field(description="The relaxation's own bound, before branching")
    root_efficiency: OptionalFloat = Field(description="The design's efficiency against that root bound")
    nodes: int
    open_leaves: int
    optimal: bool = Field(description="Every leaf closed: the design is proven optimal")
    improved_design: bool = Field(description="A leaf was a better selection than exchange found: it is the design")


class BoundPublic(Public):
    """What the convex relaxation proves no selection of K can beat."""

    criterion: Criterion
    value: OptionalFloat = Field(description="In the criterion's natural units (as `value`)")
    utility: OptionalFloat = Field(description="The concave utility the relaxation bounds")
    certified: bool
    method: str
    solver_status: str
    note: str | None = optional("What the bound does not account for (e.g. min_spread)")
    branch_and_bound: BranchAndBoundPublic | None = optional("With bound_seconds > 0")


class RelaxationPublic(Public):
    method: str | None
    status: str
    iterations: int
    seconds: float
    exchange_swaps: int
    information_s: float
    relaxation_s: float
    greedy_exchange_s: float
    rounding_exchange_s: float
    random_baseline_s: float


class ConstraintsPublic(Public):
    offered: int = Field(description="Candidates before the filters")
    excluded: dict[str, int] = Field(description="Candidates each filter removed")
    min_spread: float | None
    d_efficiency_floor: float | None


class CurvePointPublic(Public):
    """Predicted TCP error after calibration with `count` poses (mm): the chosen criterion's design, the D and I
    designs, the median of random selections, and the certified bound (no selection can do better)."""

    count: int
    rms_tcp_mm: OptionalFloat = None
    max_tcp_mm: OptionalFloat = None
    D_rms_tcp_mm: OptionalFloat = None
    I_rms_tcp_mm: OptionalFloat = None
    D_max_tcp_mm: OptionalFloat = None
    I_max_tcp_mm: OptionalFloat = None
    random_rms_tcp_mm: OptionalFloat = None
    random_max_tcp_mm: OptionalFloat = None
    bound_rms_tcp_mm: OptionalFloat = None


class PoseDesignReportPublic(Public):
    """What a pose design computed: stored once, as validated here, and served as stored."""

    criterion: Criterion
    measurement: DesignMeasurement
    count: int
    poses: list[list[float]] = Field(description="K joint vectors, mm and deg")
    indices: list[int] | None = Field(description="Into the given candidates; null when they were sampled")
    # The design's own reports are null only in target mode when the fixed poses already reach the target
    # (count 0: nothing to choose).
    value: OptionalFloat = Field(description="The exact criterion of the chosen poses")
    metrics: DesignMetricsPublic | None
    random_baseline: DesignMetricsPublic | None = Field(description="Median over random selections of the same size")
    greedy: GreedyPublic | None
    bound: BoundPublic | None
    efficiency: OptionalFloat = Field(description="Against the bound; 1 = as good as the relaxation")
    relaxation: RelaxationPublic | None
    identifiable: list[str]
    candidates: int
    fixed: int
    seconds: float
    notes: list[str]
    constraints: ConstraintsPublic | None
    target: DesignTarget | None = optional("Target mode: what was asked")
    curve: list[CurvePointPublic] | None = optional("Target mode: error against K")
    reachable_mm: OptionalFloat = optional("Target mode: with every candidate measured")
    temperature_c: list[float] | None = optional("With terms and levels: each chosen pose's temperature (°C)")
    payload_kg: list[float] | None = optional("With terms and levels: each chosen pose's payload")
    fixed_mm: OptionalFloat = optional("Target mode: with the fixed poses alone")
    references: list[str] | None = optional(MEASURED_DOC)
    cell: DesignCellPublic | None = optional("With a cell: what it checked and refused")


class PoseDesignPublic(PoseDesignReportPublic):
    id: str
    robot_id: str
    created_at: datetime


class PoseDesignSummaryPublic(Public):
    """One stored design in a robot's list; GET /v1/pose-designs/{id} has the whole report."""

    id: str
    robot_id: str
    created_at: datetime
    criterion: Criterion
    measurement: DesignMeasurement
    count: int
    value: OptionalFloat
