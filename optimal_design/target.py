"""How many poses: the smallest K whose design reaches a predicted TCP accuracy, and the curve behind it.

The accuracy of a design is the predicted TCP position error after
calibration (criteria.metrics): the RMS over the workspace sample
(`rms_tcp_mm`, √trace(L M⁻¹)) or its worst pose (`max_tcp_mm`). Measuring every
candidate gives the most information any selection can have (each pose adds a
positive semi-definite term), so the error with all candidates (and the fixed
poses) is the best reachable value: a target below it is refused at once with
`TargetUnreachable`, saying what can be reached.

The search probes K with real designs (criterion D or I): a first probe at
twice the identifiability minimum, then predictions from the √K law of
information (error ∝ 1/√K) until the target is bracketed, then bisection. It
assumes, as the designs behave, that a design's error does not rise with K;
tests check the answer against an exhaustive scan of every K on a small
problem. Every probed K enters the curve with the D and I designs' errors and
the median of random selections of the same size, all from the same run.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Unpack

import numpy as np

from models import RobotDescription
from models._types import Array
from models.engine.blas import single_threaded_blas
from models.errors import InvalidInput, TargetUnreachable, TooFewMeasurements
from optimal_design.criteria import I_OPTIMAL, Criterion, DesignCriterion, criterion_of, metrics, names
from optimal_design.information import max_tcp_error
from optimal_design.problem import DesignInputs, DesignOptions, DesignProblem
from optimal_design.relaxation import first_order
from optimal_design.report import PoseDesign
from optimal_design.solve import solve

METRICS = {"rms_tcp_mm": "predicted_rms_tcp_mm", "max_tcp_mm": "predicted_max_tcp_mm"}
MAX_PROBES = 40
CURVE = (Criterion.D, Criterion.I)
"""The criteria whose designs every point of the curve reports (its `D_…` and `I_…` errors)."""


@dataclass(frozen=True)
class TargetDesign:
    target: dict[str, float]
    """{"rms_tcp_mm": x} or {"max_tcp_mm": x}."""
    count: int
    """The smallest K whose design reaches the target (0 when the fixed poses already do)."""
    design: PoseDesign | None
    """The design at `count` (None when count is 0)."""
    curve: tuple[dict[str, Any], ...]
    """Every probed K: the error of the D and I designs and of random poses (median), and the chosen one's."""
    reachable_mm: float
    """The error with every admissible candidate measured: nothing below it can be reached."""
    fixed_mm: float | None
    """The error of the fixed poses alone (None without fixed poses or when they identify nothing)."""
    measurement: str
    """The kind of measurement designed for (what the report says even when no pose is needed)."""
    seconds: float
    notes: tuple[str, ...] = field(default=())


def _error(problem: DesignProblem, m: Array, key: str) -> float:
    if key == "max_tcp_mm":
        assert problem.info.task_rows is not None
        return max_tcp_error(problem.info.task_rows, m)
    return metrics(m, 1, problem.info.task)["predicted_rms_tcp_mm"]


@single_threaded_blas
def design_for_target(
    desc: RobotDescription,
    *,
    rms_tcp_mm: float | None = None,
    max_tcp_mm: float | None = None,
    criterion: str | Criterion | DesignCriterion = Criterion.I,
    measurement: str = "pose",
    **options: Unpack[DesignOptions],
) -> TargetDesign:
    """The smallest K (beyond `fixed`) whose `criterion` design (D or I) reaches the target, and the curve."""
    started = time.perf_counter()
    inputs = DesignInputs(measurement=measurement, **options)
    problem = DesignProblem.build(desc, inputs)
    target = Target.of(rms_tcp_mm, max_tcp_mm, criterion)
    return target_on(desc, problem, target, seed=inputs.seed, measurement=measurement, started=started)


@dataclass(frozen=True)
class Target:
    """One accuracy goal: which error (`key`: rms_tcp_mm or max_tcp_mm), its value in mm, the criterion."""

    key: str
    goal: float
    criterion: Criterion

    @classmethod
    def of(
        cls, rms_tcp_mm: float | None, max_tcp_mm: float | None, criterion: str | Criterion | DesignCriterion
    ) -> Target:
        key, goal = _goal(rms_tcp_mm, max_tcp_mm)
        return cls(key, goal, _targetable(criterion))


def target_on(
    desc: RobotDescription, problem: DesignProblem, target: Target, *, seed: int, measurement: str, started: float
) -> TargetDesign:
    """The target mode on a built problem (a tracker's candidates, or a reference's: optimal_design.references)."""
    key, goal, crit = target.key, target.goal, target.criterion
    info = problem.info
    notes: list[str] = []
    fixed_mm = _error(problem, problem.base, key) if problem.n_fixed and problem.minimum_count() == 0 else None
    if fixed_mm is not None and fixed_mm <= goal:
        return TargetDesign(
            target={key: goal},
            count=0,
            design=None,
            curve=(),
            reachable_mm=_error(problem, problem.base + info.information(np.ones(info.size)), key),
            fixed_mm=fixed_mm,
            measurement=measurement,
            seconds=time.perf_counter() - started,
            notes=("the fixed poses already reach the target: no more are needed",),
        )
    reachable = _error(problem, problem.base + info.information(np.ones(info.size)), key)
    if reachable > goal:
        raise TargetUnreachable(
            f"no selection of the {info.size} candidates reaches a predicted {_label(key)} of {goal:g} mm: "
            f"measuring every one of them gives {reachable:.4g} mm, the best reachable; add candidates, measure "
            "the full pose rather than the position, or relax the target",
            field=key,
            target_mm=goal,
            reachable_mm=reachable,
            candidates=int(info.size),
        )
    search = _Search(desc, problem, crit, key=key, goal=goal, seed=seed)
    count = search.smallest(max(1, problem.minimum_count()), info.size)
    if count is None:
        raise _spread_too_tight(search, problem.spread.minimum if problem.spread is not None else None, reachable)
    if problem.spread is not None:
        notes.append("min_spread applies to every design of the curve; random poses ignore it")
    return TargetDesign(
        target={key: goal},
        count=count,
        design=search.designs[(crit, count)],
        curve=tuple(search.curve()),
        reachable_mm=reachable,
        fixed_mm=fixed_mm,
        measurement=measurement,
        seconds=time.perf_counter() - started,
        notes=tuple(notes),
    )


def _goal(rms_tcp_mm: float | None, max_tcp_mm: float | None) -> tuple[str, float]:
    """(which error, its target) of the one target given."""
    given = {k: v for k, v in (("rms_tcp_mm", rms_tcp_mm), ("max_tcp_mm", max_tcp_mm)) if v is not None}
    if len(given) != 1:
        raise InvalidInput("give exactly one target: rms_tcp_mm or max_tcp_mm")
    key, goal = next(iter(given.items()))
    if not math.isfinite(goal) or goal <= 0:
        raise InvalidInput(
            f"the target {key} must be a positive number of millimetres, got {goal}", field=key, value=goal, min=0.0
        )
    return key, goal


def _targetable(criterion: str | Criterion | DesignCriterion) -> Criterion:
    crit = criterion_of(criterion).name
    targetable = names(lambda c: c.targetable)
    if crit not in targetable:
        raise InvalidInput(
            f"the target mode designs with the {' or '.join(targetable)} criterion (I minimises the "
            f"predicted RMS TCP error), not {crit.value}",
            field="criterion",
            value=crit.value,
            allowed=[c.value for c in targetable],
        )
    return crit


def _spread_too_tight(search: _Search, min_spread: float | None, reachable: float) -> TargetUnreachable:
    """No design reached the goal though every candidate would: the spread is what keeps it away."""
    key, goal, size = search.key, search.goal, search.problem.info.size
    best = min((p[f"{search.crit.value}_{key}"] for p in search.curve()), default=math.inf)
    return TargetUnreachable(
        f"no design of up to {size} poses at min_spread {min_spread} reaches a predicted {_label(key)} "
        f"of {goal:g} mm; the best design found reaches {best:.4g} mm (every candidate, ignoring the spread, "
        f"would give {reachable:.4g} mm): lower min_spread or relax the target",
        field=key,
        target_mm=goal,
        reachable_mm=best,
        candidates=int(size),
    )


def _label(key: str) -> str:
    return "RMS TCP position error" if key == "rms_tcp_mm" else "worst-pose TCP position error"


class _Search:
    """Designs by K, computed once each, warm-started from the nearest K already solved."""

    def __init__(
        self, desc: RobotDescription, problem: DesignProblem, crit: Criterion, *, key: str, goal: float, seed: int
    ) -> None:
        self.desc, self.problem, self.crit, self.key, self.goal, self.seed = desc, problem, crit, key, goal, seed
        self.designs: dict[tuple[Criterion, int], PoseDesign] = {}
        self.too_tight: int | None = None
        self.bounds: dict[int, float] = {}
        self.relaxed: dict[int, Array] = {}

    def design(self, crit: Criterion, count: int) -> PoseDesign | None:
        if (crit, count) in self.designs:
            return self.designs[(crit, count)]
        if self.too_tight is not None and count >= self.too_tight:
            return None
        near = [k for (c, k) in self.designs if c is crit]
        start = None
        if near:
            k0 = min(near, key=lambda k: abs(k - count))
            weights = self.designs[(crit, k0)].weights
            start = None if weights is None else weights * (count / k0)
        try:
            found = solve(self.desc, self.problem, crit, count, seed=self.seed, start=start)
        except TooFewMeasurements:
            raise
        except InvalidInput as exc:
            if self.problem.spread is None or "min_spread" not in exc.data:
                raise
            self.too_tight = count if self.too_tight is None else min(self.too_tight, count)
            return None
        self.designs[(crit, count)] = found
        return found

    def error(self, count: int) -> float:
        d = self.design(self.crit, count)
        return math.inf if d is None else float(d.metrics[METRICS[self.key]])

    def bound_rms(self, count: int) -> float:
        """Certified: no selection of `count` poses has a predicted RMS TCP error below this (I relaxation)."""
        if count not in self.bounds:
            near = list(self.relaxed)
            start = None
            if near:
                k0 = min(near, key=lambda k: abs(k - count))
                start = self.relaxed[k0] * (count / k0)
            r = first_order(self.problem.info, I_OPTIMAL, count, self.problem.base, start=start)
            self.relaxed[count] = r.weights
            self.bounds[count] = math.sqrt(-r.bound) if r.bound is not None and r.bound < 0 else 0.0
        return self.bounds[count]

    def impossible_below(self, low: int, high: int) -> int:
        """The largest K that the I certificate proves cannot reach the goal (low − 1 if none): relaxations only.

        If the relaxation's bound at K is above the goal, so is the relaxation's optimum at every smaller K (less
        budget, less information), so one K certifies all below it."""
        # (for a max_tcp_mm goal too: the worst pose's error is at least the RMS)
        fail, ok = low - 1, high
        k = min(high, 2 * low)
        for _ in range(MAX_PROBES):
            if ok - fail <= 1:
                break
            b = self.bound_rms(k)
            if b > self.goal:
                fail = k
                guess = k * (b / self.goal) ** 2
                k = int(min(ok - 1, 4 * k, max(fail + 1, math.ceil(guess))))
                if k <= fail:
                    break
            else:
                ok = k
                k = (fail + ok) // 2
        return fail

    def smallest(self, low: int, high: int) -> int | None:
        """The smallest K in [low, high] whose design reaches the goal (error non-increasing in K assumed).

        Below the certified limit nothing can reach; from there the designs are probed upward with doubling
        steps until one reaches, then bisected."""
        fail = self.impossible_below(low, high)
        ok = None
        k, step = fail + 1, 1
        for _ in range(MAX_PROBES):
            if k > high:
                break
            if self.error(k) <= self.goal:
                ok = k
            else:
                fail = k
            if ok is not None and ok - fail <= 1:
                break
            if ok is None:
                k, step = min(high, fail + step), step * 2
                if k <= fail:
                    break
            else:
                k = (fail + ok) // 2
        return ok

    def curve(self) -> list[dict[str, Any]]:
        counts = sorted({k for (_, k) in self.designs})
        out = []
        for k in counts:
            for c in CURVE:
                self.design(c, k)
            point: dict[str, Any] = {"count": k}
            mine = self.designs.get((self.crit, k))
            point[self.key] = None if mine is None else mine.metrics[METRICS[self.key]]
            for c in CURVE:
                d = self.designs.get((c, k))
                point[f"{c.value}_{self.key}"] = None if d is None else d.metrics[METRICS[self.key]]
            # the I certificate: no selection of k poses has a lower predicted RMS error
            point["bound_rms_tcp_mm"] = self.bound_rms(k)
            ref = mine or next(iter(d for (c, kk), d in self.designs.items() if kk == k))
            point[f"random_{self.key}"] = ref.random_baseline[METRICS[self.key]]
            out.append(point)
        return out
