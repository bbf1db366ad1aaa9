"""What a design is compared with: random selections of the same size from the same candidates."""

from __future__ import annotations

import numpy as np

from optimal_design.criteria import metrics
from optimal_design.information import max_tcp_error
from optimal_design.problem import DesignProblem

RANDOM_DRAWS = 20


def random_baseline(problem: DesignProblem, count: int, seed: int) -> dict[str, float]:
    """Median metrics over RANDOM_DRAWS random selections of `count` admissible candidates (spread ignored)."""
    info, base = problem.info, problem.base
    rng = np.random.default_rng(seed + 1)
    draws = []
    for _ in range(RANDOM_DRAWS):
        m = base + info.subset_information(rng.choice(info.size, count, replace=False))
        d = metrics(m, problem.rows * (count + problem.n_fixed), info.task)
        if info.task_rows is not None:
            d["predicted_max_tcp_mm"] = max_tcp_error(info.task_rows, m)
        draws.append(d)
    return {k: float(np.median([d[k] for d in draws])) for k in draws[0]}
