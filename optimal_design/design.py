"""Which poses to measure: the entry point. The steps are modules of their own: the problem (problem.py), the
search (solve.py), the report (report.py) and the random baseline (baselines.py); their public names are
re-exported here."""

from __future__ import annotations

import time
from typing import Unpack

from models import RobotDescription
from models.engine.blas import single_threaded_blas
from optimal_design.baselines import RANDOM_DRAWS, random_baseline
from optimal_design.criteria import CONDITION_D_FLOOR, Criterion, DesignCriterion, criterion_of
from optimal_design.problem import (
    MAX_CANDIDATES,
    SAMPLING_ROUNDS,
    DesignInputs,
    DesignOptions,
    DesignProblem,
    Problem,
    prepare,
)
from optimal_design.report import PoseDesign, efficiency
from optimal_design.solve import solve

__all__ = [
    "CONDITION_D_FLOOR",
    "MAX_CANDIDATES",
    "RANDOM_DRAWS",
    "SAMPLING_ROUNDS",
    "DesignInputs",
    "DesignOptions",
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
    d_efficiency_floor: float | None = None,
    bound_seconds: float = 0.0,
    **options: Unpack[DesignOptions],
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

    The problem's keywords (`DesignOptions`: candidates, candidate_count, seed, fixed, noise, params,
    joint_ranges, keep_out, min_spread, runtime, conditions, levels, fixed_conditions) build `DesignInputs`, once."""
    started = time.perf_counter()
    crit = criterion_of(criterion)
    inputs = DesignInputs(measurement=measurement, **options)
    return solve(
        desc,
        DesignProblem.build(desc, inputs),
        crit,
        count,
        seed=inputs.seed,
        started=started,
        d_efficiency_floor=d_efficiency_floor,
        bound_seconds=bound_seconds,
    )
