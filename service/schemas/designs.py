"""Pose-design requests and the complete design report (boundary units: mm, degrees)."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from optimal_design.criteria import Criterion
from optimal_design.design import MAX_CANDIDATES
from service.schemas.common import JointVector, OptionalFloat, Public, Strict

MAX_FIXED = 10_000


class PoseDesignCreate(Strict):
    count: int = Field(ge=1, le=10_000, description="K, the number of poses to measure", examples=[30])
    criterion: Criterion = Criterion.D
    measurement: Literal["pose", "position"] = "pose"
    candidates: list[JointVector] | None = Field(default=None, max_length=MAX_CANDIDATES)
    candidate_count: int = Field(default=2000, ge=1, le=MAX_CANDIDATES)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    fixed: list[JointVector] | None = Field(default=None, max_length=MAX_FIXED, description="Poses already measured")


class DesignMetricsPublic(Public):
    """Of the identification problem the poses would give (identifiable parameters, scaled as it scales them).

    Null where the information matrix is singular (an infinite condition number or trace)."""

    condition_number: OptionalFloat
    log_det: OptionalFloat
    min_singular_value: OptionalFloat
    max_singular_value: OptionalFloat
    trace_inverse: OptionalFloat
    predicted_rms_tcp_mm: OptionalFloat
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


class BoundPublic(Public):
    """What the convex relaxation proves no selection of K can beat."""

    criterion: Criterion
    value: OptionalFloat = Field(description="In the criterion's natural units (as `value`)")
    utility: OptionalFloat = Field(description="The concave utility the relaxation bounds")
    certified: bool
    method: str
    solver_status: str


class RelaxationPublic(Public):
    method: str | None
    status: str
    iterations: int
    seconds: float
    exchange_swaps: int
    information_s: float
    relaxation_s: float
    rounding_exchange_s: float


class PoseDesignReportPublic(Public):
    """What a pose design computed: stored once, as validated here, and served as stored."""

    criterion: Criterion
    measurement: Literal["pose", "position"]
    count: int
    poses: list[list[float]] = Field(description="K joint vectors, mm and deg")
    indices: list[int] | None = Field(description="Into the given candidates; null when they were sampled")
    value: OptionalFloat = Field(description="The exact criterion of the chosen poses")
    metrics: DesignMetricsPublic
    random_baseline: DesignMetricsPublic = Field(description="Median over random selections of the same size")
    greedy: GreedyPublic
    bound: BoundPublic | None
    efficiency: OptionalFloat = Field(description="Against the bound; 1 = as good as the relaxation")
    relaxation: RelaxationPublic
    identifiable: list[str]
    candidates: int
    fixed: int
    seconds: float
    notes: list[str]


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
    measurement: Literal["pose", "position"]
    count: int
    value: OptionalFloat
