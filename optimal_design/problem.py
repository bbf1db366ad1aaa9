"""The design problem: candidates after the filters, their information, what is already measured, the spread.

Built and validated once (`DesignProblem.build`), then solved for one K or many (target mode) without change.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, TypedDict

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models import NoiseModel, RobotDescription, forward_kinematics, sample_workspace
from models._types import Array
from models.cell import Cell, check_poses
from models.description.terms import Conditions
from models.engine.runtime import Runtime
from models.errors import InvalidInput, TooFewMeasurements
from models.identifiability import measurement_rows, poses_for
from models.identification.prior import ParameterPrior
from models.kinematics import as_joint_array, check_joint_ranges
from models.measurement import MeasurementKind
from optimal_design.constraints import KeepOut, Spread, joint_range_mask, keep_out_mask
from optimal_design.information import CandidateInformation, candidate_information

MAX_CANDIDATES = 100_000
SAMPLING_ROUNDS = 20
CELL_BATCH_GROWTH = 50
"""With a cell, a next batch is at most this many times the candidates still missing."""


@dataclass(frozen=True)
class DesignInputs:
    """What a design problem is built from (see `design_poses` for each option).

    With model terms on: `conditions` are the given candidates' own (one per candidate), or `levels` the
    conditions the user can set (e.g. temperatures 16, 22, 28 °C, or payloads 0 and 40 kg): every candidate pose
    is then offered at each level, so the design chooses where to spread them. `fixed_conditions`: the fixed
    poses'."""

    measurement: str = "pose"
    candidates: ArrayLike | None = None
    candidate_count: int = 2000
    seed: int = 0
    fixed: ArrayLike | None = None
    noise: NoiseModel | None = None
    params: ArrayLike | None = None
    joint_ranges: Mapping[int, tuple[float, float]] | None = None
    keep_out: KeepOut | Sequence[Sequence[float]] | None = None
    min_spread: float | None = None
    runtime: Runtime | None = None
    conditions: Conditions | None = None
    levels: Conditions | None = None
    fixed_conditions: Conditions | None = None
    prior: ParameterPrior | None = None
    """What is known of the parameters before any pose is measured (a fleet's population, `models.evaluation.fleet`):
    its
    information joins the fixed poses' in `base`, so the designs and the target mode count the poses a MAP
    identification with that prior needs."""
    cell: Cell | None = None
    """The cell around the robot (`models.cell`): only the candidates it can measure are offered (collision-free,
    seen by its instrument); each refused one is counted in `DesignProblem.excluded` under its reason."""


class DesignOptions(TypedDict, total=False):
    """The keywords of `design_poses` and `design_for_target` that build the problem: `DesignInputs`' fields but
    the measurement (a test keeps the two in step)."""

    candidates: ArrayLike | None
    candidate_count: int
    seed: int
    fixed: ArrayLike | None
    noise: NoiseModel | None
    params: ArrayLike | None
    joint_ranges: Mapping[int, tuple[float, float]] | None
    keep_out: KeepOut | Sequence[Sequence[float]] | None
    min_spread: float | None
    runtime: Runtime | None
    conditions: Conditions | None
    levels: Conditions | None
    fixed_conditions: Conditions | None
    prior: ParameterPrior | None
    cell: Cell | None


@dataclass(frozen=True)
class DesignProblem:
    """Candidates after the filters, their information, what is already measured, and the spread constraint."""

    info: CandidateInformation
    base: Array
    n_fixed: int
    rows: int
    position_only: bool
    origin: NDArray[Any]
    """For each admissible candidate, its index among the candidates given or sampled."""
    excluded: dict[str, int]
    spread: Spread | None
    offered: int
    """How many candidates there were before the filters."""
    allowed: Array = field(init=False, repr=False)
    """Which candidates the rounding and exchange may choose: every admissible one (the filters are applied)."""

    def __post_init__(self) -> None:
        allowed = np.ones(self.info.size, dtype=bool)
        allowed.setflags(write=False)  # shared by every solve of the problem; the algorithms copy what they change
        object.__setattr__(self, "allowed", allowed)

    @classmethod
    def build(cls, desc: RobotDescription, inputs: DesignInputs) -> DesignProblem:
        """Validate, sample or check the candidates, apply the filters, and compute every candidate's
        information."""
        position_only = _position_only(inputs.measurement)
        if inputs.conditions is not None and inputs.candidates is None:
            raise InvalidInput(
                "conditions belong to given candidates; for sampled ones give levels", field="conditions"
            )
        theta = None if inputs.params is None else desc.parameters.vector(inputs.params)
        admissible = _Filters(desc, inputs, theta)
        if inputs.candidates is not None:
            cand, origin, offered, excluded = _given(desc, inputs, theta, admissible)
        else:
            cand, origin, offered, excluded = _sampled(desc, inputs, theta, admissible)
        if cand.shape[0] == 0:
            raise InvalidInput(
                "no candidate pose satisfies the joint sub-ranges, the keep-out box and the cell "
                f"(of {offered} offered: "
                f"{', '.join(f'{n} {why}' for why, n in excluded.items())})",
                field="candidates",
                reason="all_filtered",
            )
        cand, cand_conditions, origin = _with_conditions(desc, cand, origin, inputs.conditions, inputs.levels)
        done = None
        if inputs.fixed is not None:
            done = as_joint_array(desc, inputs.fixed)
            check_joint_ranges(desc, done)
        info, base = _information(desc, inputs, theta, cand, cand_conditions=cand_conditions, done=done)
        spread = Spread.of(desc, info.joints, done, float(inputs.min_spread)) if inputs.min_spread else None
        return cls(
            info=info,
            base=base,
            n_fixed=0 if done is None else done.shape[0],
            rows=measurement_rows(position_only),
            position_only=position_only,
            origin=origin,
            excluded=excluded,
            spread=spread,
            offered=offered,
        )

    def minimum_count(self) -> int:
        """Poses to choose so that, with the fixed ones, the identification accepts the campaign: the fixed poses'
        information must be completed, and the whole campaign hold `poses_for` the parameters."""
        base_rank = int(np.linalg.matrix_rank(self.base)) if self.n_fixed else 0
        completing = math.ceil((self.info.n_params - base_rank) / self.rows)
        return max(0, completing, poses_for(self.info.n_params, self.position_only) - self.n_fixed)

    def check_count(self, count: int) -> None:
        """InvalidInput or TooFewMeasurements unless `count` poses can be chosen and identify the parameters."""
        info = self.info
        if count < 1 or count > info.size:
            raise InvalidInput(
                f"count must be between 1 and the number of candidates ({info.size}), got {count}",
                field="count",
                value=count,
                min=1,
                max=int(info.size),
            )
        minimum = self.minimum_count()
        if count < minimum:
            raise TooFewMeasurements(
                f"{count} {'position-only' if self.position_only else 'full-pose'} measurements cannot identify "
                f"the {info.n_params} identifiable parameters: choose at least {minimum}",
                got=count,
                needed=minimum,
                missing=minimum - count,
                kind="position" if self.position_only else "pose",
            )


def _position_only(measurement: str) -> bool:
    return MeasurementKind.parse(measurement).position_only


class _Filters:
    """The joint sub-ranges, the keep-out box and the cell: which candidates pass, and how many each filter
    excluded (the cell's refusals under their reasons, `models.cell.Reason`)."""

    def __init__(self, desc: RobotDescription, inputs: DesignInputs, theta: Array | None) -> None:
        self.desc, self.theta, self.runtime = desc, theta, inputs.runtime
        self.box = KeepOut.of(inputs.keep_out) if inputs.keep_out is not None else None
        self.ranges = dict(inputs.joint_ranges or {})
        self.cell = inputs.cell

    def __call__(self, q: Array) -> tuple[Array, dict[str, int]]:
        ok = np.ones(q.shape[0], dtype=bool)
        counts: dict[str, int] = {}
        if self.ranges:
            inside = joint_range_mask(self.desc, q, self.ranges)
            counts["joint_ranges"] = int((~inside).sum())
            ok &= inside
        if self.box is not None:
            clear = keep_out_mask(self.desc, q, self.box, self.theta, runtime=self.runtime)
            counts["keep_out"] = int((ok & ~clear).sum())
            ok &= clear
        if self.cell is not None:
            # Only what passed the cheaper filters goes to the cell's check (frames and distances per pose).
            rows = np.flatnonzero(ok)
            seen = check_poses(self.desc, self.cell, q[rows], self.theta, runtime=self.runtime)
            counts.update(seen.counts)
            ok[rows] = seen.feasible
        return ok, counts


def _given(
    desc: RobotDescription, inputs: DesignInputs, theta: Array | None, admissible: _Filters
) -> tuple[Array, NDArray[Any], int, dict[str, int]]:
    """The given candidates that pass the filters: (joints, their indices among the given, offered, excluded)."""
    assert inputs.candidates is not None
    cand = as_joint_array(desc, inputs.candidates)
    if cand.shape[0] == 0:
        raise InvalidInput("candidates is empty: give at least `count` joint vectors, or omit them", field="candidates")
    check_joint_ranges(desc, cand)
    if inputs.conditions is not None and _size(inputs.conditions) != cand.shape[0]:
        raise InvalidInput(
            f"conditions: give one per candidate ({cand.shape[0]}), not {_size(inputs.conditions)}",
            field="conditions",
        )
    # UnreachablePose names the first candidate outside the workspace
    forward_kinematics(desc, cand, theta, runtime=inputs.runtime)
    ok, excluded = admissible(cand)
    return cand[ok], np.flatnonzero(ok), cand.shape[0], excluded


def _sampled(
    desc: RobotDescription, inputs: DesignInputs, theta: Array | None, admissible: _Filters
) -> tuple[Array, NDArray[Any], int, dict[str, int]]:
    """`candidate_count` admissible candidates sampled in the workspace: (joints, indices, offered, excluded).

    Sampling goes on until that many pass the filters (at most SAMPLING_ROUNDS batches): the filters shape where
    candidates are, not how many the design chooses from."""
    count, seed, runtime = inputs.candidate_count, inputs.seed, inputs.runtime
    if not 1 <= count <= MAX_CANDIDATES:
        raise InvalidInput(f"candidate_count must be between 1 and {MAX_CANDIDATES}, got {count}")
    cand = sample_workspace(desc, count, seed=seed, params=theta, runtime=runtime)
    ok, excluded = admissible(cand)
    offered = cand.shape[0]
    if not ok.all():
        rng = np.random.default_rng([seed, 1])
        kept, total = [cand[ok]], int(ok.sum())
        for _ in range(SAMPLING_ROUNDS):
            if total >= count:
                break
            size = _batch(inputs, count - total, total, offered)
            if size <= 0:
                break
            more = sample_workspace(desc, size, seed=rng, params=theta, runtime=runtime)
            more_ok, more_excluded = admissible(more)
            kept.append(more[more_ok])
            total += int(more_ok.sum())
            offered += more.shape[0]
            for k, v in more_excluded.items():
                excluded[k] = excluded.get(k, 0) + v
        cand = np.vstack(kept)[:count]
    return cand, np.arange(cand.shape[0]), offered, excluded


def _batch(inputs: DesignInputs, missing: int, kept: int, offered: int) -> int:
    """The next batch to sample: `candidate_count` as before; with a cell (which may refuse most poses: a
    reflector's cone sees a few percent of random orientations), sized by the share kept so far so that one
    or two more batches complete the set, each check amortising its batched frames over many poses."""
    if inputs.cell is None:
        return inputs.candidate_count
    share = max(kept / max(offered, 1), 1.0 / CELL_BATCH_GROWTH)
    # At most MAX_CANDIDATES offered in all (~5 s of checks): a cell that sees almost nothing gets a design on
    # the fewer candidates it kept, its report saying how many were offered and why they were refused.
    return int(min(MAX_CANDIDATES - offered, math.ceil(1.2 * missing / share) + 16))


def _information(
    desc: RobotDescription,
    inputs: DesignInputs,
    theta: Array | None,
    cand: Array,
    *,
    cand_conditions: Conditions | None,
    done: Array | None,
) -> tuple[CandidateInformation, Array]:
    """The candidates' information and the fixed poses' (`done`), from one evaluation of both."""
    n_fixed = 0 if done is None else done.shape[0]
    joints = cand if done is None else np.vstack([done, cand])
    all_conditions = _stacked(desc, n_fixed, inputs.fixed_conditions, cand.shape[0], cand_conditions)
    info_all = candidate_information(
        desc,
        joints,
        position_only=_position_only(inputs.measurement),
        noise=inputs.noise,
        params=theta,
        conditions=all_conditions,
        runtime=inputs.runtime,
    )
    base = info_all.subset_information(np.arange(n_fixed)) if n_fixed else np.zeros((info_all.n_params,) * 2)
    if inputs.prior is not None:
        base = base + prior_information(desc, inputs.prior, info_all.free)
    info = replace(
        info_all,
        joints=info_all.joints[n_fixed:],
        blocks=info_all.blocks[n_fixed:],
        conditions=cand_conditions,
    )
    return info, base


def prior_information(desc: RobotDescription, prior: ParameterPrior, free: tuple[int, ...]) -> Array:
    """The prior's information on the identifiable parameters, in the design's scaling (tolerance units): the
    rows MAP identification stacks (`models.identification.prior`), so diag(scaleᵢ² / sᵢ²) where it covers."""
    rows = prior.information_rows(desc.parameters)[:, list(free)]
    return np.asarray(rows.T @ rows, dtype=float)


def _with_conditions(
    desc: RobotDescription, cand: Array, origin: NDArray[Any], conditions: Conditions | None, levels: Conditions | None
) -> tuple[Array, Conditions | None, NDArray[Any]]:
    """The admissible candidates with their conditions: their own, or each pose at every level."""
    if not desc.terms.any or (conditions is None and levels is None):
        return cand, None, origin
    if conditions is not None:
        return cand, conditions.subset(origin), origin
    assert levels is not None
    n_levels = _size(levels)
    m = cand.shape[0]
    pick = np.tile(np.arange(n_levels), m)
    return np.repeat(cand, n_levels, axis=0), levels.subset(pick), np.repeat(origin, n_levels)


def _size(c: Conditions) -> int:
    for part in (c.temperature_c, c.payload_kg):
        if part is not None:
            return int(part.shape[0])
    raise InvalidInput("levels: give temperatures or payloads to spread", field="levels")


def _stacked(
    desc: RobotDescription, n_fixed: int, fixed: Conditions | None, n_cand: int, cand: Conditions | None
) -> Conditions | None:
    """The conditions of the fixed poses then the candidates (reference conditions where none are given)."""
    if not desc.terms.any or (fixed is None and cand is None):
        return None

    def part(c: Conditions | None, n: int, name: str) -> Array:
        value = None if c is None else getattr(c, name)
        if value is not None:
            return np.asarray(value, dtype=float)
        if name == "temperature_c":
            return np.full(n, desc.terms.reference_temperature_c)
        return np.zeros((n, 3)) if name == "payload_cog_mm" else np.zeros(n)

    names = ("temperature_c", "payload_kg", "payload_cog_mm")
    stacked = [np.concatenate([part(fixed, n_fixed, k), part(cand, n_cand, k)]) for k in names]
    return Conditions(*stacked)


def prepare(desc: RobotDescription, measurement: str = "pose", **options: Any) -> DesignProblem:
    """`DesignProblem.build` with the options as keywords (DesignInputs' fields)."""
    return DesignProblem.build(desc, DesignInputs(measurement=measurement, **options))


Problem = DesignProblem
"""The former name."""
