"""User bounds on named parameters, as bounds on the solver's unknowns (tolerance units from the start)."""

from __future__ import annotations

import numpy as np

from models._types import Array
from models.errors import InvalidInput
from models.identification.options import IdentificationOptions
from models.identification.residuals import CampaignProblem


def solver_bounds(problem: CampaignProblem, options: IdentificationOptions) -> tuple[Array, Array]:
    """(lower, upper) on z; ±inf where a parameter has no bound. Bounds of parameters not estimated are
    checked, then ignored (those parameters stay at their start values)."""
    table = problem.desc.parameters
    lower = np.full(problem.n_free, -np.inf)
    upper = np.full(problem.n_free, np.inf)
    position = {int(j): k for k, j in enumerate(problem.free)}
    for name, (lo, hi) in options.bounds.items():
        if name not in table.index:
            raise InvalidInput(f"bounds are set per parameter, and {name!r} is not a parameter name", field=name)
        # NaN compares false both ways, so it is rejected on its own; -inf/+inf mean "no bound".
        if np.isnan(lo) or np.isnan(hi):
            raise InvalidInput(f"bounds of {name}: ({lo}, {hi}) are not numbers (use ±inf for no bound)", field=name)
        if lo > hi:
            raise InvalidInput(f"bounds of {name}: lower {lo} is above upper {hi}", field=name)
        i = table.index[name]
        k = position.get(i)
        if k is None:
            continue
        start, scale = problem.theta_start[i], problem.scales[k]
        lower[k], upper[k] = (lo - start) / scale, (hi - start) / scale
    return lower, upper
