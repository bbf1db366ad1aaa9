"""What a design reports: the chosen poses, their criterion and metrics, the certificate and the baselines."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

from numpy.typing import NDArray

from models import RobotDescription
from models._types import Array
from models.description.terms import Conditions
from optimal_design.baselines import random_baseline
from optimal_design.criteria import Criterion, DesignCriterion, criterion_of, metrics
from optimal_design.information import max_tcp_error
from optimal_design.problem import DesignProblem
from optimal_design.relaxation import Relaxation

Index = NDArray[Any]


@dataclass(frozen=True)
class PoseDesign:
    criterion: Criterion
    position_only: bool
    joints: Array
    """(K, n_joints) chosen poses, internal units."""
    indices: tuple[int, ...]
    """Into the candidates (given or sampled)."""
    value: float
    """The exact criterion of the chosen poses (criteria.value)."""
    metrics: dict[str, float]
    random_baseline: dict[str, float]
    greedy: dict[str, Any]
    bound: dict[str, Any] | None
    efficiency: float | None
    relaxation: dict[str, Any]
    identifiable: tuple[str, ...]
    candidates: int
    fixed: int
    seconds: float
    notes: tuple[str, ...] = field(default=())
    weights: Array | None = None
    """The relaxation's weights over the admissible candidates (a warm start for a neighbouring K)."""
    constraints: dict[str, Any] = field(default_factory=dict)
    """Candidates offered, excluded by each filter, and the minimum spread."""
    conditions: Conditions | None = None
    """The chosen poses' conditions (temperature, payload) where the model has terms."""


@dataclass(frozen=True)
class Found:
    """What `solve` found: the answer, the greedy baseline, and how the search went."""

    chosen: Index
    utility: float
    relaxed: Relaxation | None
    swaps: int
    """Exchange swaps from the rounded start (from the greedy start when the relaxation failed)."""
    greedy: Index | None
    greedy_utility: float
    greedy_swaps: int
    greedy_seconds: float
    branched: dict[str, Any] | None
    notes: tuple[str, ...]
    timings: dict[str, float]
    d_efficiency_floor: float | None


def finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def efficiency(criterion: str | DesignCriterion, design_utility: float, bound: float, n_params: int) -> float:
    """Design against the bound, 1 = as good as the relaxation (D: per-parameter geometric mean)."""
    return criterion_of(criterion).efficiency(design_utility, bound, n_params)


def pose_design(
    desc: RobotDescription,
    problem: DesignProblem,
    crit: DesignCriterion,
    count: int,
    found: Found,
    *,
    seed: int,
    started: float,
) -> PoseDesign:
    """The report of `found`, with the random baseline drawn from the same candidates."""
    info, base = problem.info, problem.base
    relaxed, chosen = found.relaxed, found.chosen
    m = base + info.subset_information(chosen)
    t0 = time.perf_counter()
    baseline = random_baseline(problem, count, seed)
    timings = {**found.timings, "random_baseline_s": time.perf_counter() - t0}
    metric = metrics(m, problem.rows * (count + problem.n_fixed), info.task)
    if info.task_rows is not None:
        metric["predicted_max_tcp_mm"] = max_tcp_error(info.task_rows, m)
    bound = relaxed.bound if relaxed is not None else None
    return PoseDesign(
        criterion=crit.name,
        position_only=problem.position_only,
        joints=info.joints[chosen],
        conditions=None if info.conditions is None else info.conditions.subset(chosen),
        indices=tuple(int(problem.origin[i]) for i in chosen),
        value=crit.value(m, info.task),
        metrics=metric,
        random_baseline=baseline,
        greedy=_greedy_report(problem, crit, found, bound),
        bound=_bound_report(problem, crit, found),
        efficiency=None if bound is None else crit.efficiency(found.utility, bound, info.n_params),
        relaxation={
            "method": relaxed.method if relaxed else None,
            "status": relaxed.status if relaxed else "failed",
            "iterations": relaxed.iterations if relaxed else 0,
            "seconds": relaxed.seconds if relaxed else 0.0,
            "exchange_swaps": found.swaps,
            **timings,
        },
        identifiable=tuple(desc.parameters.names[i] for i in info.free),
        candidates=info.size,
        fixed=problem.n_fixed,
        seconds=time.perf_counter() - started,
        notes=found.notes,
        weights=relaxed.weights if relaxed is not None else None,
        constraints={
            "offered": problem.offered,
            "excluded": dict(problem.excluded),
            "min_spread": problem.spread.minimum if problem.spread is not None else None,
            "d_efficiency_floor": found.d_efficiency_floor,
        },
    )


def _greedy_report(problem: DesignProblem, crit: DesignCriterion, found: Found, bound: float | None) -> dict[str, Any]:
    info = problem.info
    design = found.greedy
    return {
        "value": finite(crit.value(problem.base + info.subset_information(design), info.task))
        if design is not None
        else None,
        "efficiency": finite(crit.efficiency(found.greedy_utility, bound, info.n_params))
        if bound is not None and design is not None
        else None,
        "swaps": found.greedy_swaps,
        "seconds": found.greedy_seconds,
    }


def _bound_report(problem: DesignProblem, crit: DesignCriterion, found: Found) -> dict[str, Any] | None:
    relaxed = found.relaxed
    if relaxed is None or relaxed.bound is None:
        return None
    report: dict[str, Any] = {
        "criterion": crit.name.value,
        "value": finite(crit.reading(relaxed.bound)),
        "utility": relaxed.bound,
        "certified": True,
        "method": relaxed.method,
        "solver_status": relaxed.status,
    }
    if found.branched is not None:
        report["branch_and_bound"] = found.branched
    if problem.spread is not None:
        report["note"] = "the bound ignores min_spread (a relaxation of it), so it stays valid but looser"
    return report
