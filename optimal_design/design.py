"""Which poses to measure: the entry point. The steps are modules of their own: the problem (problem.py), the
search (solve.py), the report (report.py) and the random baseline (baselines.py); their public names are
re-exported here."""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence

from numpy.typing import ArrayLike

from models import NoiseModel, RobotDescription
from models.blas import single_threaded_blas
from models.runtime import Runtime
from models.terms import Conditions
from optimal_design.baselines import RANDOM_DRAWS, random_baseline
from optimal_design.constraints import KeepOut
from optimal_design.criteria import CONDITION_D_FLOOR, Criterion, DesignCriterion, criterion_of
from optimal_design.problem import MAX_CANDIDATES, SAMPLING_ROUNDS, DesignInputs, DesignProblem, Problem, prepare
from optimal_design.report import PoseDesign, efficiency
from optimal_design.solve import solve

__all__ = [
    "CONDITION_D_FLOOR",
    "MAX_CANDIDATES",
    "RANDOM_DRAWS",
    "SAMPLING_ROUNDS",
    "DesignInputs",
    "DesignProblem",
    "PoseDesign",
    "Problem",
    "design_poses",
    "efficiency",
    "prepare",
    "random_baseline",
    "solve",
]


@single_threaded_blas
def design_poses(
    desc: RobotDescription,
    count: int,
    criterion: str | Criterion | DesignCriterion = Criterion.D,
    measurement: str = "pose",
    *,
    candidates: ArrayLike | None = None,
    candidate_count: int = 2000,
    seed: int = 0,
    fixed: ArrayLike | None = None,
    noise: NoiseModel | None = None,
    params: ArrayLike | None = None,
    joint_ranges: Mapping[int, tuple[float, float]] | None = None,
    keep_out: KeepOut | Sequence[Sequence[float]] | None = None,
    min_spread: float | None = None,
    d_efficiency_floor: float | None = None,
    runtime: Runtime | None = None,
    bound_seconds: float = 0.0,
    conditions: Conditions | None = None,
    levels: Conditions | None = None,
    fixed_conditions: Conditions | None = None,
) -> PoseDesign:
    """Choose `count` poses among candidates (given, or `candidate_count` sampled in the workspace).

    `joint_ranges` ({joint index: (low, high)}, internal units) and `keep_out` (a world-frame box, two corners in
    mm, that the TCP and the platform centre must stay outside) filter the candidates; `min_spread` (0-1, the
    metric of optimal_design.constraints) keeps the chosen poses apart from each other and from `fixed`.
    `d_efficiency_floor` (E and condition only, 0-1): optimise the criterion over designs whose D-efficiency
    against the certified D bound stays at least this (README: why the plain condition design calibrates the TCP
    little better than random poses, and what this buys). None: CONDITION_D_FLOOR for the condition criterion
    (lowered to what the D design reaches if that is less), no floor for the others; 0: no floor.
    `bound_seconds` (D, A, I): spend up to this long tightening the certificate by branch and bound
    (optimal_design.branching); the design does not change, its bound can only get lower. With model terms on,
    `conditions`, `levels` and `fixed_conditions` give the candidates' and fixed poses' conditions (see
    `DesignInputs`): the chosen ones come back in `PoseDesign.conditions`.

    The keywords stay spelled out (rather than one options object) because the service, the benchmarks and the
    tests call this with them; the problem's share of them is `DesignInputs`, built here once."""
    started = time.perf_counter()
    crit = criterion_of(criterion)
    inputs = DesignInputs(
        measurement=measurement,
        candidates=candidates,
        candidate_count=candidate_count,
        seed=seed,
        fixed=fixed,
        noise=noise,
        params=params,
        joint_ranges=joint_ranges,
        keep_out=keep_out,
        min_spread=min_spread,
        runtime=runtime,
        conditions=conditions,
        levels=levels,
        fixed_conditions=fixed_conditions,
    )
    return solve(
        desc,
        DesignProblem.build(desc, inputs),
        crit,
        count,
        seed=seed,
        started=started,
        d_efficiency_floor=d_efficiency_floor,
        bound_seconds=bound_seconds,
    )
