"""The design of K poses on a built problem: relaxation, greedy and rounded starts improved by exchange, an
optional D-efficiency floor, and branch and bound on the certificate."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from models import RobotDescription
from models._types import Array
from models.errors import InvalidInput
from optimal_design.branching import tighten
from optimal_design.constraints import Spread
from optimal_design.criteria import (
    D_OPTIMAL,
    I_OPTIMAL,
    DesignCriterion,
    SpectralCriterion,
    criterion_of,
    listing,
    names,
)
from optimal_design.exchange import exchange, greedy, round_weights
from optimal_design.information import CandidateInformation
from optimal_design.problem import DesignProblem
from optimal_design.relaxation import Relaxation, relax
from optimal_design.report import Found, PoseDesign, efficiency, finite, pose_design

Index = NDArray[Any]


@dataclass
class _Log:
    """The notes and step timings a solve collects on its way, and the D relaxation once made (the E and
    condition relaxations start from it, and the D-efficiency floor is measured against its bound)."""

    notes: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    d_relaxation: Relaxation | None = None

    def d_relaxed(self, problem: DesignProblem, count: int, start: Array | None = None) -> Relaxation:
        if self.d_relaxation is None:
            self.d_relaxation = relax(problem.info, D_OPTIMAL, count, problem.base, start=start)
        return self.d_relaxation


@dataclass(frozen=True)
class _Floor:
    """A D-efficiency floor kept by the design: log det at least `log_det`, `start` a D design above it."""

    log_det: float
    start: Index


def solve(
    desc: RobotDescription,
    problem: DesignProblem,
    crit: str | DesignCriterion,
    count: int,
    *,
    seed: int = 0,
    started: float | None = None,
    start: Array | None = None,
    d_efficiency_floor: float | None = None,
    bound_seconds: float = 0.0,
) -> PoseDesign:
    """The design of `count` poses on a built problem; `start` warm-starts the relaxation (weights)."""
    started = time.perf_counter() if started is None else started
    criterion = criterion_of(crit)
    found = search(
        problem,
        criterion,
        count,
        started=started,
        start=start,
        d_efficiency_floor=d_efficiency_floor,
        bound_seconds=bound_seconds,
    )
    return pose_design(desc, problem, criterion, count, found, seed=seed, started=started)


def search(
    problem: DesignProblem,
    crit: str | DesignCriterion,
    count: int,
    *,
    started: float | None = None,
    start: Array | None = None,
    d_efficiency_floor: float | None = None,
    bound_seconds: float = 0.0,
) -> Found:
    """The search of `solve` without its report: what any problem's design is, whatever its candidates are (a
    chain's poses, a tree's records, `optimal_design.tree`)."""
    started = time.perf_counter() if started is None else started
    criterion = criterion_of(crit)
    problem.check_count(count)
    log = _Log(timings={"information_s": time.perf_counter() - started})
    relaxed = _relaxation(problem, criterion, count, start, log)
    floor, applied = _d_floor_of(problem, criterion, count, d_efficiency_floor, log)
    g_design, g_swaps, g_utility = _greedy_start(problem, criterion, count, floor=floor, relaxed=relaxed, log=log)
    r_design, r_swaps, r_utility = _rounded_start(
        problem, criterion, count, relaxed, floor=floor, greedy=(g_design, g_swaps, g_utility), log=log
    )
    chosen, chosen_utility = r_design, r_utility
    if g_design is not None and g_utility > r_utility:
        chosen, chosen_utility = g_design, g_utility
        log.notes.append("the greedy start ended better than the rounded relaxation after exchange: it is the answer")
    if not math.isfinite(bound_seconds) or bound_seconds < 0:
        raise InvalidInput(
            f"bound_seconds must be >= 0, got {bound_seconds}", field="bound_seconds", value=bound_seconds, min=0
        )
    branched: dict[str, Any] | None = None
    if bound_seconds > 0 and relaxed is not None and relaxed.bound is not None:
        relaxed, chosen, chosen_utility, branched = _branch_and_bound(
            problem,
            criterion,
            count,
            relaxed,
            chosen=chosen,
            chosen_utility=chosen_utility,
            seconds=bound_seconds,
            log=log,
        )
    return Found(
        chosen=chosen,
        utility=chosen_utility,
        relaxed=relaxed,
        swaps=r_swaps,
        greedy=g_design,
        greedy_utility=g_utility,
        greedy_swaps=g_swaps,
        greedy_seconds=log.timings["greedy_exchange_s"],
        branched=branched,
        notes=tuple(log.notes),
        timings=log.timings,
        d_efficiency_floor=applied,
    )


def _relaxation(
    problem: DesignProblem, crit: DesignCriterion, count: int, start: Array | None, log: _Log
) -> Relaxation | None:
    """The relaxation, or None (noted) when it fails: the design is then the greedy one."""
    t0 = time.perf_counter()
    relaxed: Relaxation | None
    try:
        d = log.d_relaxed(problem, count, start) if isinstance(crit, SpectralCriterion) else None
        relaxed = relax(problem.info, crit, count, problem.base, start=start, d_relaxation=d)
    except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
        relaxed = None
        log.notes.append(f"the relaxation failed ({exc}); the design is the greedy one, improved by exchange")
    log.timings["relaxation_s"] = time.perf_counter() - t0
    if relaxed is not None and relaxed.note:
        log.notes.append(relaxed.note)
    return relaxed


def _d_floor_of(
    problem: DesignProblem, crit: DesignCriterion, count: int, asked: float | None, log: _Log
) -> tuple[_Floor | None, float | None]:
    """(the floor to keep, or None; the D-efficiency floor applied, as the report states it)."""
    soft = asked is None and crit.default_d_floor is not None
    if soft:
        asked = crit.default_d_floor
    if asked is None or asked == 0:
        return None, asked
    threshold, start, applied = _d_floor(problem, crit, count, asked, log, soft=soft)
    return _Floor(threshold, start), applied


def _greedy_start(
    problem: DesignProblem,
    crit: DesignCriterion,
    count: int,
    *,
    floor: _Floor | None,
    relaxed: Relaxation | None,
    log: _Log,
) -> tuple[Index | None, int, float]:
    """The D-greedy design improved by exchange: (design, swaps, utility); None when no greedy design keeps the
    spread (and the relaxation can stand in)."""
    info, base, spread = problem.info, problem.base, problem.spread
    t0 = time.perf_counter()
    g_design: Index | None = None
    g_swaps, g_utility = 0, -math.inf
    try:
        g_start = greedy(info, count, base, problem.allowed, spread)
        if floor is not None and float(np.linalg.slogdet(base + info.subset_information(g_start))[1]) < floor.log_det:
            g_start = floor.start  # the greedy start is below the D-efficiency floor: start it from the D design
        g_design, g_swaps = exchange(
            info,
            crit,
            g_start,
            base=base,
            allowed=problem.allowed,
            spread=spread,
            log_det_floor=None if floor is None else floor.log_det,
            wide=crit.wide_greedy_exchange,
        )
        g_utility = crit.utility(base + info.subset_information(g_design), info.task)
    except InvalidInput as exc:
        if spread is None or relaxed is None:
            raise
        log.notes.append(f"no greedy start at this spread ({exc.detail})")
    log.timings["greedy_exchange_s"] = time.perf_counter() - t0
    return g_design, g_swaps, g_utility


def _rounded_start(
    problem: DesignProblem,
    crit: DesignCriterion,
    count: int,
    relaxed: Relaxation | None,
    *,
    floor: _Floor | None,
    greedy: tuple[Index | None, int, float],
    log: _Log,
) -> tuple[Index, int, float]:
    """The relaxation rounded (or the floor's D design), improved by exchange: (design, swaps, utility); the
    greedy start's (`greedy`) when the relaxation failed."""
    t0 = time.perf_counter()
    if relaxed is None:
        assert greedy[0] is not None
        log.timings["rounding_exchange_s"] = time.perf_counter() - t0
        return greedy[0], greedy[1], greedy[2]
    found = _rounded(problem, crit, count, relaxed, floor=floor, g_design=greedy[0])
    log.timings["rounding_exchange_s"] = time.perf_counter() - t0
    return found


def _rounded(
    problem: DesignProblem,
    crit: DesignCriterion,
    count: int,
    relaxed: Relaxation,
    *,
    floor: _Floor | None,
    g_design: Index | None,
) -> tuple[Index, int, float]:
    info, base, spread = problem.info, problem.base, problem.spread
    try:
        start_design = round_weights(relaxed.weights, count, problem.allowed, spread) if floor is None else floor.start
    except InvalidInput:
        if g_design is None:
            raise
        start_design = g_design
    if g_design is not None and not _positive_definite(base + info.subset_information(start_design)):
        # Rounding can lose rank where each candidate adds few rows (a ballbar's one distance): the exchange scores
        # swaps through the inverse information, so it starts from the greedy design, full rank by construction.
        start_design = g_design
    log_det_floor = None if floor is None else floor.log_det
    if crit.proxy_start:
        start_design = _smooth_start(info, relaxed.weights, start_design, base, spread=spread, floor=log_det_floor)
    r_design, r_swaps = exchange(
        info,
        crit,
        start_design,
        base=base,
        allowed=problem.allowed,
        weights=relaxed.weights,
        spread=spread,
        log_det_floor=log_det_floor,
    )
    return r_design, r_swaps, crit.utility(base + info.subset_information(r_design), info.task)


def _positive_definite(m: Array) -> bool:
    try:
        np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        return False
    return True


def _branch_and_bound(
    problem: DesignProblem,
    crit: DesignCriterion,
    count: int,
    relaxed: Relaxation,
    *,
    chosen: Index,
    chosen_utility: float,
    seconds: float,
    log: _Log,
) -> tuple[Relaxation, Index, float, dict[str, Any] | None]:
    """(the relaxation with the tightened bound, the design and its utility, the search's report) after up to
    `seconds` of branch and bound; the criteria it does not apply to keep the relaxation's bound (noted)."""
    if not crit.branchable:
        which = listing(names(lambda c: c.branchable))
        log.notes.append(f"bound_seconds applies to {which}; the {crit.name.value} bound is the relaxation's")
        return relaxed, chosen, chosen_utility, None
    info = problem.info
    tight = tighten(info, crit, count, problem.base, relaxed, incumbent=chosen_utility, seconds=seconds)
    branched = {
        "seconds": tight.seconds,
        "root_utility": tight.root,
        "root_efficiency": finite(efficiency(crit, chosen_utility, tight.root, info.n_params)),
        "nodes": tight.nodes,
        "open_leaves": tight.open_leaves,
        "optimal": tight.closed,
        "improved_design": tight.better is not None,
    }
    if tight.better is not None and problem.spread is None:  # the search ignores the spread
        chosen, chosen_utility = np.sort(tight.better), tight.incumbent
        log.notes.append("branch and bound found a better design than exchange: it is the answer")
    relaxed = replace(relaxed, bound=tight.bound, method=relaxed.method + "; tightened by branch and bound")
    return relaxed, chosen, chosen_utility, branched


def _smooth_start(
    info: CandidateInformation,
    weights: Array,
    design: Index,
    base: Array,
    *,
    spread: Spread | None,
    floor: float | None,
) -> Index:
    """Improve an E / condition start on a smooth proxy first: trace(Z M⁻¹) with Z the weakest directions of the
    relaxed design, each weighted by 1/λ (an A-criterion that only looks where λ_min lives).

    λ_min is flat almost everywhere and jumps where the weakest directions cross, so single spectral swaps stall
    early; the proxy has exact low-rank swap values (exchange's I route) and moves the design where the relaxation
    put its weight. Measured at K = 30 of 2 000 (spectral pools 12 / 48): E 0.719 -> 0.743 and condition
    0.843 -> 0.860 efficiency after the spectral exchange that follows, for ~0.3 s."""
    ev, vec = np.linalg.eigh(base + info.information(weights))
    weak = ev <= 1.5 * ev[0]
    z = (vec[:, weak] / ev[weak]) @ vec[:, weak].T
    proxy = replace(info, task=z)
    allowed = np.ones(info.size, dtype=bool)
    better, _ = exchange(
        proxy,
        I_OPTIMAL,
        design,
        base=base,
        allowed=allowed,
        weights=weights,
        spread=spread,
        log_det_floor=floor,
        wide=False,  # only a start: the spectral exchange that follows checks the wide pool
    )
    return better


def _d_floor(
    problem: DesignProblem, crit: DesignCriterion, count: int, floor: float, log: _Log, *, soft: bool = False
) -> tuple[float, Index, float]:
    """(log det floor, a D design above it, the D-efficiency floor applied) for a design that keeps a
    D-efficiency floor.

    `soft` (a criterion's default floor): a floor above what the D design reaches is lowered to it instead of
    refused."""
    # Long on purpose: the floor's three cases (none, reached, lowered) each need the D design and its bound
    # built above.
    if not crit.takes_d_floor:
        raise InvalidInput(
            f"d_efficiency_floor applies to the {listing(names(lambda c: c.takes_d_floor))} criteria, "
            f"not {crit.name.value}",
            field="d_efficiency_floor",
            reason="criterion",
            value=crit.name.value,
        )
    if not math.isfinite(floor) or not 0.0 < floor <= 1.0:
        raise InvalidInput(
            f"d_efficiency_floor must be in [0, 1] (0: no floor), got {floor}",
            field="d_efficiency_floor",
            value=floor,
            min=0,
            max=1,
        )
    info, base, notes = problem.info, problem.base, log.notes
    d = log.d_relaxed(problem, count)
    if d.bound is None:
        raise InvalidInput("the D relaxation gave no bound: no D-efficiency floor can be enforced")
    threshold = d.bound + info.n_params * math.log(floor)
    start, _ = exchange(
        info,
        D_OPTIMAL,
        round_weights(d.weights, count, problem.allowed, problem.spread),
        base=base,
        allowed=problem.allowed,
        weights=d.weights,
        spread=problem.spread,
    )
    reached = float(np.linalg.slogdet(base + info.subset_information(start))[1])
    if reached < threshold and soft:
        # Reported as the D design's own efficiency is (criteria.utility, from the eigenvalues): on the
        # ill-conditioned M of 10 poses slogdet differs from it by ~2e-7, which left the applied floor 3e-9 above
        # the efficiency the D design reports.
        attained = D_OPTIMAL.utility(base + info.subset_information(start), info.task)
        lowered = min(1.0, math.exp((min(reached, attained) - d.bound) / info.n_params))
        notes.append(
            f"the default D-efficiency floor {floor:g} is above what the D design reaches here ({lowered:.4f}): "
            "the floor is that"
        )
        threshold, floor = reached, lowered
    if reached < threshold:
        best = math.exp((reached - d.bound) / info.n_params)
        raise InvalidInput(
            f"d_efficiency_floor {floor:g} is above what the D design reaches here ({best:.4f}): lower it",
            field="d_efficiency_floor",
            value=floor,
            max=best,
        )
    notes.append(
        f"{crit.name.value} optimised over designs with D-efficiency >= {floor:.4g} against the certified D bound"
        f"{' (the default; d_efficiency_floor=0 turns it off)' if soft else ''}; "
        f"the {crit.name.value} bound is that of the unconstrained problem (valid, looser)"
    )
    return threshold, start, floor
