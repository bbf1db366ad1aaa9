"""Quick checks (docs/checks.md): a few tracker records against the current version, the verdict, what best
explains a change and what to do; the poses to measure for one; a robot's history. Boundary units: mm, degrees."""

from __future__ import annotations

from datetime import datetime
from typing import Literal

from pydantic import Field

from models.evaluation.checks import CheckAction, CheckOptions, Verdict
from optimal_design.checks import MAX_CHECK_POSES, MIN_CHECK_POSES
from service.record_kinds import CampaignRecord, ReferenceDescriptions
from service.schemas.calibrations import Instrument, InstrumentPublic, Noise
from service.schemas.common import (
    STRICT_BY_ALIAS,
    ConditionWarningPublic,
    FreeText,
    ImportNotes,
    ImportNotesPublic,
    JointVector,
    Measurement,
    Public,
    Strict,
    optional,
)

_OPTIONS = CheckOptions()
MAX_CHECK_RECORDS = 200
Against = Literal["version", "tolerances"]


class QuickCheckCreate(ReferenceDescriptions):
    """Records measured now (5-10 are typical; at least 3), against the robot's current version: a tracker's, or
    distance, point and plane records with their references described (their unknowns are fitted with the robot
    held, in place of the instrument frame; `register` does not apply to them)."""

    model_config = STRICT_BY_ALIAS
    measurements: list[CampaignRecord] = Field(min_length=1, max_length=MAX_CHECK_RECORDS)
    noise: Noise = Field(default_factory=Noise, description="The instrument's σ (each record's own sigma_mm wins)")
    alpha: float = Field(
        default=_OPTIONS.alpha,
        gt=0,
        lt=0.5,
        description="The false-alarm rate: the probability that a robot which did not change is not called fine",
    )
    fit_frame: bool = Field(
        default=_OPTIONS.register,
        alias="register",
        description="Fit the instrument frame first (closed form; its 6 unknowns leave the test's degrees of "
        "freedom). false: the tracker stands where it stood for the calibration, so its frame is the version's base",
    )
    change_sigmas: float = Field(
        default=_OPTIONS.change_sigmas,
        gt=0,
        le=1000,
        description="How many of its standard errors (from the noise and the version's own uncertainty) a fitted "
        "change must be to explain the check",
    )
    drift_ratio: float = Field(
        default=_OPTIONS.drift_ratio,
        gt=1,
        le=1e6,
        description="χ²/dof up to which a misfit no single parameter or group explains is drift, not a change",
    )
    against: Against = Field(
        default="version",
        description="version: the uncertainty the version's calibration left (a robot never calibrated is refused); "
        "tolerances: the parameters' nominal tolerances, for a robot that only has its nominal version",
    )
    notes: FreeText | None = None
    instrument: Instrument | None = None
    import_notes: ImportNotes


class CheckStatisticPublic(Public):
    chi2: float = Field(description="The whitened residuals' sum of squares")
    dof: int = Field(description="Rows minus the registration's 6 where registered")
    threshold: float = Field(description="χ²(dof) at 1 − alpha")
    p_value: float
    alpha: float


class ParameterChangePublic(Public):
    name: str
    unit: str
    change: float = Field(description="The fitted change, in the parameter's unit")
    std_error: float = Field(description="Of the change, from the check's records")
    calibrated_std_error: float = Field(description="The parameter's σ in the version (0: held without one)")


class CheckExplanationPublic(Public):
    name: str = Field(description="The parameter or group whose change was fitted")
    parameters: list[ParameterChangePublic]
    chi2_after: float
    dof_after: int
    reduction: float = Field(description="How much χ² the change removes")
    p_value: float = Field(description="Of the reduction, were nothing changed")
    explains: bool = Field(description="Significant, large, and leaving a statistic below its own threshold")


class CheckRecommendationPublic(Public):
    action: CheckAction
    parameters: list[str] = Field(description="What to re-fit (action refit)")
    poses: int = Field(description="Designed poses to measure for it (0: nothing to do)")
    message: str


class CheckRecordErrorPublic(Public):
    position_mm: float = Field(description="|measured − predicted| after the registration")
    predicted_mm: float = Field(description="The 1-σ size the test expects of it (noise and the version's σ)")


class QuickCheckPublic(Public):
    id: str
    robot_id: str
    campaign_id: str
    created_at: datetime
    version: int
    against: Against
    verdict: Verdict
    statistic: CheckStatisticPublic
    registered: bool
    measurement: Measurement
    measurements: int
    per_record: list[CheckRecordErrorPublic]
    explanation: CheckExplanationPublic | None = Field(description="What best explains a change (verdict changed)")
    alternatives: list[CheckExplanationPublic] = Field(
        description="The next candidates: those that also explain it, fewest parameters first, then the rest by "
        "the χ² they leave"
    )
    recommendation: CheckRecommendationPublic
    seconds: float
    notes: str | None
    instrument: InstrumentPublic | None
    warnings: list[ConditionWarningPublic] = Field(
        default_factory=list,
        description="The records' temperature or payload outside what the version was calibrated under",
    )
    import_notes: ImportNotesPublic


class QuickCheckDesignCreate(Strict):
    model_config = STRICT_BY_ALIAS
    count: int = Field(default=8, ge=MIN_CHECK_POSES, le=MAX_CHECK_POSES)
    measurement: Literal["position", "pose"] = "position"
    fit_frame: bool = Field(default=_OPTIONS.register, alias="register", description="As the check will")
    watch: list[str] | None = Field(
        default=None,
        min_length=1,
        max_length=200,
        description="Groups or parameters whose changes to see best (default: the joint offsets and the tool, "
        "and the base for a check without registration)",
    )
    candidate_count: int = Field(default=500, ge=20, le=5000, description="Workspace samples to choose among")
    seed: int = Field(default=0, ge=0, le=2**31 - 1)
    noise: Noise = Field(default_factory=Noise)
    alpha: float = Field(default=_OPTIONS.alpha, gt=0, lt=0.5)
    against: Against = "version"


class CheckWatchedPublic(Public):
    name: str
    unit: str
    detectable: float | None = Field(
        description="The change of it alone the check flags with 95 % probability (null: the check cannot see it)"
    )


class CheckPosePublic(Public):
    joints: JointVector


class QuickCheckDesignPublic(Public):
    robot_id: str
    version: int
    measurement: Literal["position", "pose"]
    registered: bool
    poses: list[CheckPosePublic]
    watched: list[CheckWatchedPublic]
    criterion: float = Field(description="log det(I + the watched parameters' information beyond the frame's)")
    candidates: int


class HistoryEventPublic(Public):
    at: datetime
    kind: Literal["calibration", "check"]
    id: str
    version: int | None = Field(description="A calibration's new version (null: not applied); a check's version")
    outcome: str = Field(description="A calibration's status (applied or not); a check's verdict")
    rms_mm: float | None = optional(
        "The accuracy measured then: a calibration's RMS TCP residual after its fit, a check's RMS "
        "|measured − predicted| (mm); null where none was computed"
    )
    predicted_mm: float | None = optional(
        "What was expected: a calibration's predicted 1-σ TCP accuracy over the workspace, the RMS of "
        "a check's predicted errors (mm)"
    )
    drift_mm: float | None = optional("A drift-aware calibration's instrument drift over its campaign (mm)")
