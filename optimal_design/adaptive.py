"""An adaptive campaign: measure a pose, re-identify, choose the next pose on the new estimate, stop when the
predicted accuracy reaches the target (or the pose budget is spent).

The loop keeps no state of its own between steps: `advance` takes the records so far, the records already
excluded as blunders, the last estimate and the poses already asked for, and answers the next step. A service
stores those (and the pool, which `Pool.build` samples from the seed) and calls it again after a restart.

- The first poses are the identifiable minimum plus `INITIAL_SPARE` (`Pool.initial`), chosen greedily by D:
  spare rows so that every record's residual can be tested; before that many records nothing is identified.
- Each update re-identifies on the records not excluded (`models.identification.identify`, warm-started from
  the last estimate, plain least squares: the blunder test below decides what is left out, not a robust loss).
- The predicted accuracy is the target mode's (`optimal_design.target`): √tr(L M⁻¹) (RMS over the workspace
  sample) or the worst pose's, with M the records' information at the current estimate (σ of the noise model).
- The next pose is the candidate not yet asked for that improves the criterion most
  (`optimal_design.adaptive_scores`), on the information at the current estimate.

A blunder is a record whose studentized residual after the update, rᵢᵀ(I − Hᵢᵢ)⁻¹rᵢ with r the σ-weighted
residual rows and Hᵢᵢ the record's block of the hat matrix, exceeds the χ² quantile with the tail of a 5σ
normal deviate (5.7e-7): dividing by I − Hᵢᵢ undoes the pull of the record on the estimate (a blunder in a
campaign near its minimum is otherwise absorbed by the fit and its raw residual looks clean). At that tail a
clean campaign of 100 records is flagged once in ~17 000 campaigns, while a 0.5 mm blunder at σ 0.025 mm
(20σ) is still far out. The worst record beyond the threshold is excluded, the estimate recomputed, and the
test repeated; the excluded record's pose is asked for again (its information is what the design wanted;
in a cell, only when it is a pool candidate, which the cell checked).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from models import NoiseModel, RobotDescription
from models._types import Array
from models.campaign import Campaign
from models.cell import Cell
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput, TargetUnreachable
from models.identification import IdentificationOptions, IdentificationResult, RobustLoss, identify
from models.identification.pipeline import check_enough
from models.identification.statistics import chi2_upper_quantile
from models.kinematics import solve_platforms
from models.measurement import MeasurementKind
from models.measurements import ModelBatch, measurement
from optimal_design.adaptive_scores import AdaptiveCriterion, safe_inverse, scores
from optimal_design.criteria import metrics
from optimal_design.information import CandidateInformation, candidate_information, max_tcp_error
from optimal_design.problem import DesignInputs, DesignProblem

INITIAL_SPARE = 2
"""Poses beyond the identifiable minimum in the first batch: the redundancy that lets each record be tested."""
BLUNDER_SIGMA = 5.0
MAX_BLUNDERS_PER_STEP = 3
"""A step excludes at most this many records: more far-out ones at once is a wrong model or σ, not blunders."""
SAME_POSE_RAD = 1e-3
"""A record answers an asked pose when every joint is within this (0.06°: what a controller reports back)."""
KEYS = ("rms_tcp_mm", "max_tcp_mm")
LEVERAGE_FLOOR = 1e-6
"""Below this, 1 − leverage of a record leaves its studentized residual undefined."""


@dataclass(frozen=True)
class AdaptiveSettings:
    """What an adaptive campaign is asked for (internal units)."""

    target_mm: float
    target_key: str = "rms_tcp_mm"
    """Which predicted error the target is for: rms_tcp_mm (over the workspace) or max_tcp_mm (its worst pose)."""
    budget: int = 60
    """At most this many records (blunders included: each was measured)."""
    measurement: str = "pose"
    criterion: AdaptiveCriterion = AdaptiveCriterion.I
    candidate_count: int = 500
    seed: int = 0
    noise: NoiseModel = field(default_factory=NoiseModel)
    blunder_sigma: float = BLUNDER_SIGMA
    cell: Cell | None = None

    def __post_init__(self) -> None:
        if self.target_key not in KEYS:
            raise InvalidInput(f"target_key must be one of {KEYS}", field="target_key", value=self.target_key)
        if not (math.isfinite(self.target_mm) and self.target_mm > 0):
            raise InvalidInput("the target must be a positive number of millimetres", field="target_mm")
        if self.budget < 1:
            raise InvalidInput("the pose budget must be at least 1", field="budget", value=self.budget)
        if not self.blunder_sigma > 0:
            raise InvalidInput("blunder_sigma must be positive", field="blunder_sigma")

    @property
    def kind(self) -> MeasurementKind:
        return MeasurementKind.parse(self.measurement)


@dataclass(frozen=True)
class Pool:
    """The candidates (after the cell's and the joint limits' filters) and the first batch among them."""

    joints: Array
    """(M, n_joints) internal units."""
    initial: tuple[int, ...]
    """Indices of the first poses to measure (a D-optimal design of the identifiable minimum + spare)."""
    reachable_mm: float
    """The predicted error with every candidate measured (at the nominal): no campaign on this pool goes lower."""
    excluded: dict[str, int]
    """Candidates the filters refused, by reason (the cell's)."""
    offered: int = 0
    """Candidates sampled and checked to keep `joints` (more than kept where a cell refused some)."""
    in_cell: bool = False
    """Whether a cell filtered the pool: then only its poses are asked for (a blunder's pose again only when it is
    one of them: a record posted at the start may have been measured anywhere)."""

    @classmethod
    def build(
        cls,
        desc: RobotDescription,
        settings: AdaptiveSettings,
        *,
        params: Array | None = None,
        runtime: Runtime | None = None,
    ) -> Pool:
        """Sample the pool from the seed (the same pool every time), refuse an unreachable target, design the start
        (at `params`, the robot's current values; None: the nominal)."""
        inputs = DesignInputs(
            params=params,
            measurement=settings.measurement,
            candidate_count=settings.candidate_count,
            seed=settings.seed,
            noise=settings.noise,
            cell=settings.cell,
            runtime=runtime,
        )
        problem = DesignProblem.build(desc, inputs)
        info = problem.info
        reachable = predicted(info, info.information(np.ones(info.size)))[settings.target_key]
        if reachable > settings.target_mm:
            raise TargetUnreachable(
                f"measuring every one of the {info.size} candidates predicts {reachable:.4g} mm "
                f"({settings.target_key}), above the target {settings.target_mm:g} mm: add candidates, measure the "
                "full pose rather than the position, or relax the target",
                field="target_mm",
                target_mm=settings.target_mm,
                reachable_mm=reachable,
                candidates=int(info.size),
            )
        count = min(info.size, problem.minimum_count() + INITIAL_SPARE)
        start = _greedy_start(info, count)
        return cls(info.joints, start, reachable, dict(problem.excluded), problem.offered, settings.cell is not None)

    def again(self, joints: Array) -> Array | None:
        """The pose to measure again for a blunder at `joints`: itself, or in a cell the pool's candidate it was
        measured at (None when it is none of them: the cell never checked it)."""
        if not self.in_cell:
            return joints
        gap = np.abs(self.joints - joints).max(axis=1)
        best = int(np.argmin(gap))
        return self.joints[best] if gap[best] <= SAME_POSE_RAD else None


def _greedy_start(info: CandidateInformation, count: int) -> tuple[int, ...]:
    """The first `count` poses, each the one that raises log det(M) most given those before (the ridge standing in
    for the parameters none determines yet).

    A whole D design of so few poses is the relaxation's hardest case (the identifiable minimum plus two of 2 000
    candidates: 5.3 s, against 30 of them in 0.3 s), while the campaign that follows reached the target with the
    same number of records from either start on the five seeds of `benchmarks/bench_adaptive.py`."""
    m = np.zeros((info.n_params, info.n_params))
    chosen: list[int] = []
    for _ in range(count):
        value = scores(AdaptiveCriterion.D, m, info.blocks, task=info.task, task_rows=None)
        value[chosen] = -np.inf
        best = int(np.argmax(value))
        chosen.append(best)
        m = m + info.blocks[best].T @ info.blocks[best]
    return tuple(chosen)


def predicted(info: CandidateInformation, m: Array) -> dict[str, float]:
    """The target mode's predicted errors (mm) of information `m`: RMS over the workspace sample, and worst."""
    rms = metrics(m, 1, info.task)["predicted_rms_tcp_mm"]
    assert info.task_rows is not None
    return {"rms_tcp_mm": rms, "max_tcp_mm": max_tcp_error(info.task_rows, m)}


@dataclass(frozen=True)
class Blunder:
    record: int
    """Its index among every record posted (0-based)."""
    statistic: float
    """rᵢᵀ(I − Hᵢᵢ)⁻¹rᵢ: χ² with `rows` degrees of freedom for a clean record."""
    threshold: float
    position_mm: float
    """The record's position error against the estimate of the other records (its deleted residual), mm."""


@dataclass(frozen=True)
class Progress:
    """What the campaign has so far: every record, those excluded, the last estimate, the poses asked for."""

    records: Campaign
    excluded: frozenset[int] = frozenset()
    estimate: Array | None = None
    asked: tuple[int, ...] = ()
    """Pool indices already asked for (never offered twice)."""


@dataclass(frozen=True)
class Step:
    """The outcome of one update."""

    identified: bool
    estimate: Array | None
    predicted: dict[str, float] | None
    """rms_tcp_mm and max_tcp_mm at the current estimate (None before the records identify anything)."""
    blunders: tuple[Blunder, ...]
    """Flagged and excluded in this step."""
    excluded: frozenset[int]
    next_joints: Array
    """(k, n_joints) the poses to measure next (empty when done)."""
    next_pool: tuple[int, ...]
    """Their pool indices (-1 for a replacement of a blunder's pose taken from the record itself)."""
    done: bool
    reason: str | None
    result: IdentificationResult | None = None
    notes: tuple[str, ...] = ()
    replaces: tuple[int, ...] = ()
    """The blunder records whose poses the -1 entries of `next_pool` measure again, in their order."""


def advance(
    desc: RobotDescription,
    pool: Pool,
    settings: AdaptiveSettings,
    progress: Progress,
    *,
    runtime: Runtime | None = None,
) -> Step:
    """One update: re-identify (excluding blunders), predict, decide whether to stop, and choose what is next."""
    rt = runtime_for(desc, runtime)
    records = progress.records
    excluded = set(progress.excluded)
    if not _enough(desc, records, excluded, rt):
        return _before_identification(pool, settings, progress)
    result, blunders = _identify_clean(desc, settings, progress, excluded, rt)
    theta = np.asarray(result.parameters, dtype=float)
    active = records.subset(_active(records, excluded))
    info = candidate_information(
        desc,
        np.vstack([active.joints, pool.joints]),
        position_only=settings.kind.position_only,
        noise=settings.noise,
        params=theta,
        runtime=rt,
    )
    m = info.subset_information(np.arange(active.size))
    errors = predicted(info, m)
    done, reason = _stop(settings, errors, records.size)
    if done:
        empty = np.empty((0, desc.n_joints))
        return Step(True, theta, errors, blunders, frozenset(excluded), empty, (), True, reason, result)
    joints, chosen, again = _next(settings, pool, progress, blunders, _Now(info, m, active.size))
    if not joints.shape[0]:
        reason = "every candidate has been asked for: the pool is spent before the target"
        return Step(True, theta, errors, blunders, frozenset(excluded), joints, (), True, reason, result)
    kept = frozenset(excluded)
    return Step(True, theta, errors, blunders, kept, joints, chosen, False, None, result, replaces=again)


def _active(records: Campaign, excluded: set[int]) -> NDArray[np.intp]:
    return np.array([i for i in range(records.size) if i not in excluded], dtype=np.intp)


def _enough(desc: RobotDescription, records: Campaign, excluded: set[int], rt: Runtime) -> bool:
    """Whether the records not excluded are as many as the identification needs."""
    if records.size == 0:
        return False
    candidates = desc.parameters.indices(IdentificationOptions().estimate)
    try:
        check_enough(desc, records.subset(_active(records, excluded)), tuple(candidates), runtime=rt)
    except InvalidInput:
        return False
    return True


def _before_identification(pool: Pool, settings: AdaptiveSettings, progress: Progress) -> Step:
    """Too few records to identify: the first batch's poses not yet measured (or, past it, the next of it)."""
    pending = _pending(pool, progress)
    if not pending:
        # Records of other poses than asked (or blunders excluded before a fit): the start design's unasked rest.
        pending = [i for i in pool.initial if i not in progress.asked] or [
            i for i in range(pool.joints.shape[0]) if i not in progress.asked
        ][:1]
    if progress.records.size >= settings.budget:
        empty = np.empty((0, pool.joints.shape[1]))
        why = "the pose budget is spent before the records identify the robot"
        return Step(False, None, None, (), progress.excluded, empty, (), True, why)
    chosen = tuple(pending)
    return Step(False, None, None, (), progress.excluded, pool.joints[list(chosen)], chosen, False, None)


def _pending(pool: Pool, progress: Progress) -> list[int]:
    """Asked poses no record answers yet (a record answers a pose measured at its joints)."""
    joints = progress.records.joints
    out = []
    for i in progress.asked:
        if i < 0:
            continue
        if joints.shape[0] == 0 or np.abs(joints - pool.joints[i]).max(axis=1).min() > SAME_POSE_RAD:
            out.append(i)
    return out


def _stop(settings: AdaptiveSettings, errors: dict[str, float], count: int) -> tuple[bool, str | None]:
    key, goal = settings.target_key, settings.target_mm
    if errors[key] <= goal:
        return True, f"the predicted {key} {errors[key]:.4g} mm reaches the target {goal:g} mm"
    if count >= settings.budget:
        return True, (
            f"the pose budget of {settings.budget} records is spent; the predicted {key} is {errors[key]:.4g} mm, "
            f"above the target {goal:g} mm"
        )
    return False, None


@dataclass(frozen=True)
class _Now:
    """The information at the current estimate: the records' (`m`) and the pool's rows after them."""

    info: CandidateInformation
    """Of the active records, then the pool, in that order."""
    m: Array
    n_active: int

    def pool_part(self, index: NDArray[np.intp]) -> CandidateInformation:
        rows = self.info.blocks[self.n_active :][index]
        return replace(self.info, joints=self.info.joints[self.n_active :][index], blocks=rows, conditions=None)


def _next(
    settings: AdaptiveSettings, pool: Pool, progress: Progress, blunders: tuple[Blunder, ...], now: _Now
) -> tuple[Array, tuple[int, ...], tuple[int, ...]]:
    """A blunder's pose again (its information is what the design wanted; in a cell only a pose of the pool),
    else pending asked poses, else the candidate not asked for yet that improves the criterion most; and the
    blunders whose poses are asked again.

    One pose ahead, not a plan of the rest: relaxing the D or I design that completes the records at each step
    and asking for its best pose changed no count on three seeds from this start (17 records each), at 0.1-2.5 s
    a step."""
    again = [(b.record, pool.again(progress.records.joints[b.record])) for b in blunders]
    poses = [(record, q) for record, q in again if q is not None]
    if poses:
        return np.vstack([q for _, q in poses]), tuple(-1 for _ in poses), tuple(r for r, _ in poses)
    pending = _pending(pool, progress)
    if pending:
        return pool.joints[pending], tuple(pending), ()
    asked = set(progress.asked)
    free = np.array([i for i in range(pool.joints.shape[0]) if i not in asked], dtype=np.intp)
    if not free.size:
        return np.empty((0, pool.joints.shape[1])), (), ()
    part = now.pool_part(free)
    value = scores(settings.criterion, now.m, part.blocks, task=part.task, task_rows=part.task_rows)
    best = int(free[int(np.argmax(value))])
    return pool.joints[[best]], (best,), ()


def _identify_clean(
    desc: RobotDescription, settings: AdaptiveSettings, progress: Progress, excluded: set[int], rt: Runtime
) -> tuple[IdentificationResult, tuple[Blunder, ...]]:
    """Identify on the records not excluded; while the worst studentized record is beyond the threshold (and
    enough records stay), exclude it and identify again. `excluded` gains the new blunders."""
    options = IdentificationOptions(robust=RobustLoss.NONE, exclude_outliers=False)
    records, found = progress.records, list[Blunder]()
    start = progress.estimate
    threshold = blunder_threshold(settings.blunder_sigma, measurement(records.kind).rows)
    for _ in range(MAX_BLUNDERS_PER_STEP + 1):
        active = _active(records, excluded)
        result = identify(
            desc, records.subset(active), noise=settings.noise, nominal=start, options=options, runtime=rt
        )
        if not result.succeeded or len(found) == MAX_BLUNDERS_PER_STEP:
            break
        stat, position = studentized(desc, records.subset(active), result, settings.noise, rt)
        worst = int(np.nanargmax(stat)) if np.isfinite(stat).any() else -1
        if worst < 0 or stat[worst] <= threshold or not _enough(desc, records, excluded | {int(active[worst])}, rt):
            break
        found.append(Blunder(int(active[worst]), float(stat[worst]), threshold, float(position[worst])))
        excluded.add(int(active[worst]))
        start = result.parameters
    return result, tuple(found)


def blunder_threshold(sigma: float, rows: int) -> float:
    """The χ²(rows) value a clean record exceeds as rarely as a normal deviate exceeds `sigma` (two-sided)."""
    return chi2_upper_quantile(math.erfc(sigma / math.sqrt(2.0)), rows)


def studentized(
    desc: RobotDescription, campaign: Campaign, result: IdentificationResult, noise: NoiseModel, rt: Runtime
) -> tuple[Array, Array]:
    """Each record's rᵀ(I − Hᵢᵢ)⁻¹r at the estimate (NaN where its leverage is 1: untestable), and the norm of
    its position residual against the estimate of the other records (mm): a blunder's own size, which the
    residual in the fit that includes it understates (measured: 0.16 mm shown of a 0.5 mm blunder, 8 records)."""
    theta = np.asarray(result.parameters, dtype=float)
    kind = measurement(campaign.kind)
    platforms, _ = solve_platforms(desc, campaign.joints, theta, runtime=rt)
    model = ModelBatch(rt.kinematics, campaign.joints, theta, platforms, campaign.condition_inputs(desc))
    res, jac = kind.residual_jacobians(model, campaign, np.arange(campaign.size, dtype=np.intp))
    w = kind.weights(noise, campaign.sigma_mm, campaign.size)
    free = list(result.estimated)
    a = jac[:, :, free] * w[:, :, None] * desc.parameters.scales[free][None, None, :]
    flat = a.reshape(-1, len(free))
    hat = np.einsum("nip,pq,njq->nij", a, safe_inverse(flat.T @ flat), a)
    rest = np.eye(kind.rows)[None] - hat
    r = res * w
    stat, deleted = np.full(campaign.size, np.nan), np.full(campaign.size, np.nan)
    for i in range(campaign.size):
        # a record with leverage 1 fixes its own direction alone: no residual can show it wrong
        if np.linalg.eigvalsh(rest[i]).min() > LEVERAGE_FLOOR:
            # (I − Hᵢᵢ)⁻¹rᵢ is the residual against the fit of the other records (exact for a linear model)
            alone = np.linalg.solve(rest[i], r[i])
            stat[i] = float(r[i] @ alone)
            deleted[i] = float(np.linalg.norm(alone[:3] / w[i, :3]))
    return stat, deleted
