"""Adaptive campaigns (docs/pose-design.md "Adaptive campaigns"): ask for a pose, post its record, get the updated
estimate, the predicted accuracy and the next pose, until the target or the pose budget. Boundary units: mm,
degrees."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from optimal_design.adaptive import BLUNDER_SIGMA
from optimal_design.adaptive_scores import AdaptiveCriterion
from optimal_design.problem import MAX_CANDIDATES
from service.record_kinds.tracker import Record
from service.schemas.calibrations import Noise
from service.schemas.cells import CellDocument, DesignCellPublic
from service.schemas.common import FreeText, Public, Strict, optional

MAX_ADAPTIVE_BUDGET = 1000
MAX_ADAPTIVE_CANDIDATES = min(2000, MAX_CANDIDATES)
"""Each step scores every candidate on the information at the estimate: at 2 000 a UR5-like step takes 0.5 s
and the start 1.1 s (a loaded 2-core machine)."""
MAX_POSTED_RECORDS = 1000
TargetKey = Literal["rms_tcp_mm", "max_tcp_mm"]
AdaptiveStatus = Literal["measuring", "done", "finished", "ended"]


class AdaptiveCampaignCreate(Strict):
    target_mm: float = Field(gt=0, le=100, description="The predicted TCP position error to reach (mm)")
    target: TargetKey = Field(
        default="rms_tcp_mm",
        description="Which predicted error the target is for: the RMS over the workspace (as a pose design's "
        "target mode) or its worst pose",
    )
    budget: int = Field(default=60, ge=1, le=MAX_ADAPTIVE_BUDGET, description="At most this many records")
    measurement: Literal["pose", "position"] = Field(
        default="pose", description="What the tracker records: the TCP's pose (6-DOF probe) or its position"
    )
    criterion: AdaptiveCriterion = Field(
        default=AdaptiveCriterion.I,
        description="What each next pose improves most: D (every parameter), I (the predicted RMS TCP error), "
        "worst (the predicted error at the worst workspace pose)",
    )
    candidate_count: int = Field(default=500, ge=20, le=MAX_ADAPTIVE_CANDIDATES)
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    noise: Noise = Field(default_factory=Noise, description="The instrument's σ")
    blunder_sigma: float = Field(
        default=BLUNDER_SIGMA,
        ge=3,
        le=100,
        description="A record whose studentized residual is beyond this many σ (as rarely as a normal deviate) "
        "is a blunder: excluded, reported, and its pose asked for again",
    )
    cell: Literal["stored"] | CellDocument | None = optional(
        "Ask only for poses a cell can measure (collision-free, seen by its instrument): stored (the "
        "robot's current cell, PUT …/cell) or a cell document; absent: no cell. As a pose design's `cell`"
    )
    measurements: list[Record] | None = Field(
        default=None,
        max_length=MAX_POSTED_RECORDS,
        description="Records already measured (the campaign's first step); none: the first poses are designed",
    )
    notes: FreeText | None = None


class AdaptiveRecordsCreate(Strict):
    measurements: list[Record] = Field(min_length=1, max_length=MAX_POSTED_RECORDS)


class AdaptiveFinish(Strict):
    calibrate: bool = Field(
        default=True,
        description="Store a calibration from the campaign's records (blunders left out), through the calibration "
        "path (its checks decide whether it is applied); false: only end the campaign",
    )
    apply: bool = Field(default=True, description="As a calibration's `apply`")
    notes: FreeText | None = None


class PoseToMeasurePublic(Public):
    joints: list[float] = Field(description="Joint values (degrees, mm for prismatic joints)")
    candidate: int | None = Field(description="Its index in the campaign's candidate pool (null: a blunder's pose)")
    replaces: int | None = optional("The blunder record whose pose this measures again")


class BlunderPublic(Public):
    record: int = Field(description="The record's index among every record posted to the campaign (0-based)")
    statistic: float = Field(description="rᵀ(I − H)⁻¹r of its σ-weighted residual: χ²(rows) for a clean record")
    threshold: float
    position_mm: float = Field(
        description="Its position error against the estimate of the other records (what the blunder is off by)"
    )


class PredictedPublic(Public):
    rms_tcp_mm: float = Field(description="Predicted RMS TCP position error over the workspace sample")
    max_tcp_mm: float = Field(description="At the worst workspace pose")


class EstimatePublic(Public):
    status: str
    estimated: int = Field(description="Parameters estimated")
    rms_residual_mm: float | None
    max_residual_mm: float | None
    variance_factor: float | None = Field(description="Of the fit (null without degrees of freedom)")
    noise_consistent: bool


class AdaptiveStepPublic(Public):
    number: int
    posted: int = Field(description="Records in this post")
    records: int = Field(description="Records so far, blunders included")
    identified: bool = Field(description="Whether the records so far identify the robot (false in the first batch)")
    estimate: EstimatePublic | None
    predicted: PredictedPublic | None
    blunders: list[BlunderPublic] = Field(description="Flagged and excluded at this step")
    excluded: list[int] = Field(description="Every record excluded so far")
    next: list[PoseToMeasurePublic]
    done: bool
    reason: str | None
    seconds: float
    created_at: datetime | None = None


class AdaptiveCampaignSettings(Public):
    """What a campaign and its summary both open with: which campaign, its state, and what it was asked for."""

    id: str
    robot_id: str
    version: int = Field(description="The robot's version the campaign started from")
    status: AdaptiveStatus
    target_mm: float
    target: TargetKey
    budget: int
    measurement: Literal["pose", "position"]
    criterion: AdaptiveCriterion


class AdaptiveCampaignSummaryPublic(AdaptiveCampaignSettings):
    """A campaign in a robot's list: its settings and where it stands, without its steps (GET it for those)."""

    records: int
    predicted: PredictedPublic | None
    excluded: list[int]
    steps: int = Field(description="Steps stored (records posted so many times)")
    reason: str | None
    calibration_id: str | None
    created_at: datetime
    updated_at: datetime


class AdaptiveCampaignPublic(AdaptiveCampaignSettings):
    cell: DesignCellPublic | None = optional(
        "With a cell: its stored version used, what it checked and refused by reason"
    )
    candidates: int = Field(description="Candidates in the pool")
    reachable_mm: float = Field(description="The predicted error with every candidate measured")
    records: int
    predicted: PredictedPublic | None
    excluded: list[int]
    next: list[PoseToMeasurePublic] = Field(description="What to measure now (empty once done)")
    reason: str | None
    calibration_id: str | None
    steps: list[AdaptiveStepPublic]
    created_at: datetime
    updated_at: datetime
