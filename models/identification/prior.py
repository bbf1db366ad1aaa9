"""Prior knowledge of parameters (a fleet's population, `models.evaluation.fleet`): MAP identification's extra rows.

A prior says, per parameter, "θᵢ is about μᵢ, give or take sᵢ" (independent Gaussians, internal units). In the
least-squares problem it is one more residual row per parameter with a prior, `(θᵢ − μᵢ) / sᵢ`, in σ like every
data row: the fit then minimises the posterior's negative logarithm (maximum a posteriori), its Gauss–Newton
Hessian gains the prior's information `P = diag(scaleᵢ² / sᵢ²)` (unknowns in tolerances), and the covariance
becomes `(JᵀJ / s0² + P)⁻¹`. The rows are linear in the unknowns, so they add nothing to the native evaluations.

What the rows change about identifiability is explicit: the identification stacks them under the data's scaled
Jacobian before asking which parameters are determined (`information_rows`), so a campaign too short to
determine every parameter of the structure's subset on its own still estimates them all when the prior covers
the missing directions. The prior never widens the estimated set beyond what rich data of the structure could
identify: a parameter no measurement can see stays nominal, whatever the prior says about it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.description.parameters import ParameterTable
from models.errors import InvalidInput, PriorMismatch


@dataclass(frozen=True)
class ParameterPrior:
    """Independent Gaussian priors on some of a table's parameters (internal units)."""

    names: tuple[str, ...]
    """The table's parameter names, in order (a prior belongs to one robot model)."""
    mean: Array
    """(P,) μ; NaN where a parameter has no prior."""
    spread: Array
    """(P,) s > 0; NaN where a parameter has no prior."""

    def __post_init__(self) -> None:
        mean, spread = np.asarray(self.mean, dtype=float), np.asarray(self.spread, dtype=float)
        if mean.shape != (len(self.names),) or spread.shape != mean.shape:
            raise InvalidInput("a prior gives one mean and one spread per parameter", field="prior")
        has = np.isfinite(mean)
        if not np.array_equal(has, np.isfinite(spread)) or not np.all(spread[has] > 0):
            raise InvalidInput("a prior's spreads must be positive where it gives a mean", field="prior")

    @property
    def covered(self) -> tuple[int, ...]:
        """Indices of the parameters with a prior."""
        return tuple(int(i) for i in np.flatnonzero(np.isfinite(self.mean)))

    def check(self, table: ParameterTable) -> None:
        """PriorMismatch unless the prior is of this table's parameters (same names, same order)."""
        if tuple(table.names) != self.names:
            raise PriorMismatch(
                f"the prior is of a robot with {len(self.names)} parameters ({', '.join(self.names[:3])}, …), this "
                f"robot has {len(table)} ({', '.join(table.names[:3])}, …): priors come from robots of the same "
                "structure (calibrate without a prior, or use this robot's own fleet)",
                expected=len(table),
                got=len(self.names),
            )

    def information_rows(self, table: ParameterTable) -> Array:
        """(n_prior, P) the prior's rows in the identification's column scaling (σ per tolerance): eᵢ scaleᵢ/sᵢ."""
        self.check(table)
        idx = list(self.covered)
        rows = np.zeros((len(idx), len(table)))
        rows[np.arange(len(idx)), idx] = table.scales[idx] / self.spread[idx]
        return rows

    def rows(self, theta_start: Array, free: Array, scales: Array) -> PriorRows:
        """The prior's residual rows over the unknowns z of a fit (θ[free] = θ_start[free] + scales·z)."""
        covered = np.isfinite(self.mean[free])
        k = np.flatnonzero(covered)
        i = np.asarray(free)[k]
        weight = scales[k] / self.spread[i]
        offset = (theta_start[i] - self.mean[i]) / self.spread[i]
        jacobian = np.zeros((k.size, len(free)))
        jacobian[np.arange(k.size), k] = weight
        return PriorRows(offset, jacobian)


@dataclass(frozen=True)
class PriorRows:
    """r(z) = offset + J z: the prior's rows of one fit, in σ (linear in the unknowns)."""

    offset: Array
    jacobian: Array
    """(n_prior, n_free)."""

    def residuals(self, z: Array) -> Array:
        return np.asarray(self.offset + self.jacobian @ z, dtype=float)

    @property
    def information(self) -> Array:
        """(n_free, n_free) JᵀJ: what the prior adds to the normal equations."""
        return np.asarray(self.jacobian.T @ self.jacobian, dtype=float)
