"""A fleet: robots of one model. Its population of each parameter, and how one unit compares with it.

Units of one model share their design errors (a machined length every unit gets a little long) and differ by
their own (each unit's tolerances). After a few calibrations the population of each parameter is estimated from
the units' calibrated values: its mean μ and its spread s (internal units). A new unit can then be identified
with that population as its prior (maximum a posteriori, `models.identification.prior`): what its own poses do
not yet pin down is taken from its kind, so fewer poses reach the same accuracy.

The estimate, per parameter, over the units that estimated it:

- robust: the median and the MAD find the bulk; units more than `CLIP` robust spreads off are left out of the
  mean and the standard deviation (one mis-calibrated unit does not move the population);
- never overconfident: the spread is at least the units' own estimation σ (RMS over the units; what the data of
  one calibration could tell), and is widened by √(1 + 1/n) for the uncertainty of the mean of n units and by
  √((n − 1)/(n − 3)), the variance of Student's t, for the uncertainty of the spread itself (the predictive
  spread of a new unit: measured, 94 % of new units' parameters within 2 spreads, `tests/models/test_fleet.py`);
- of deviations from each unit's nominal values (its description's, with its own base and tool guesses): units
  of one structure document share the nominal geometry, so for the links and legs this is the population of the
  values themselves; a tool of another guess keeps its own nominal and shares the fleet's mounting deviation;
- the base is each campaign's instrument frame, not a property of the robot: `EXCLUDED_GROUPS` get no prior (a
  tool that differs from unit to unit gets a wide spread, so a weak prior, from the units themselves).

A unit is an outlier when one of its parameters lies farther off the population of the other units than a
unit of that population would with probability `OUTLIER_ALPHA` (leave-one-out: a unit never vouches for
itself).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.special

from models._types import Array
from models.description.parameters import ParameterTable
from models.errors import FleetTooSmall, InvalidInput
from models.identification.prior import ParameterPrior

MIN_UNITS = 5
"""Calibrated units (besides the one being calibrated) a population is estimated from: fewer give no spread
worth trusting (the standard deviation of 5 values is itself uncertain by ±35 %)."""
EXCLUDED_GROUPS = ("base",)
"""The instrument's frame of each campaign: not a property of the robot model."""
CLIP = 3.5
"""Units farther than this many robust spreads (1.4826 MAD) from the median leave a parameter's mean."""
OUTLIER_ALPHA = 0.01
"""A unit of the population is flagged with this probability (family-wise over its parameters): each z is
compared with Student's t quantile of its parameter's units less one degrees of freedom at α / (2 P), the spread
of a few units being itself uncertain (9 units, 23 parameters: |z| > 5.8; 19 units: 4.4)."""
FLOOR = 1e-3
"""A spread is never below this share of the parameter's scale (identical values tell nothing of a new unit)."""


@dataclass(frozen=True)
class UnitEstimate:
    """One calibrated unit: its parameters, their standard errors (NaN: not estimated) and its nominal values
    (internal units)."""

    unit: str
    values: Array
    std_errors: Array
    nominal: Array


@dataclass(frozen=True)
class UnitComparison:
    """One unit against the population of the others."""

    unit: str
    z: Array
    """(P,) (value − μ) / s per parameter; NaN where the unit or the population has no value."""
    outlier: bool
    worst: tuple[str, float] | None
    """The parameter farthest off and its z (None without any)."""
    limit: Array
    """(P,) the |z| beyond which the parameter flags the unit (NaN without a prior)."""


@dataclass(frozen=True)
class FleetPrior:
    """A population: per parameter, the mean deviation from nominal and the spread (internal units; NaN: no prior),
    and the units it is estimated from."""

    table: ParameterTable
    offset: Array
    """(P,) mean of the units' values minus their nominal ones."""
    spread: Array
    counts: Array
    """(P,) units behind each parameter's estimate (0 where none)."""
    units: tuple[str, ...]

    def prior(self, nominal: Array | None = None) -> ParameterPrior:
        """The population as a MAP prior for a unit of these `nominal` values (default: the table's):
        `IdentificationOptions.prior`, `DesignInputs.prior`."""
        base = self.table.nominal if nominal is None else self.table.vector(nominal)
        return ParameterPrior(tuple(self.table.names), base + self.offset, self.spread)

    @property
    def covered(self) -> tuple[int, ...]:
        return tuple(int(i) for i in np.flatnonzero(np.isfinite(self.offset)))

    def precision(self) -> Array:
        """(P,) 1/s² per parameter, 0 where no prior (pose design adds it to the information)."""
        out = np.zeros(len(self.table))
        idx = list(self.covered)
        out[idx] = 1.0 / self.spread[idx] ** 2
        return out

    def z_scores(self, values: Array, nominal: Array) -> Array:
        """(P,) how many spreads each value lies off the population (NaN without a prior or a value)."""
        deviation = np.asarray(values, dtype=float) - np.asarray(nominal, dtype=float)
        return np.asarray((deviation - self.offset) / self.spread, dtype=float)


def fleet_prior(
    table: ParameterTable, units: Sequence[UnitEstimate], *, minimum: int = MIN_UNITS, what: str = "the fleet"
) -> FleetPrior:
    """The population of `units` (calibrated units of the model of `table`); FleetTooSmall below `minimum`."""
    if minimum < 2:
        raise InvalidInput("a population needs at least 2 units", field="minimum", min=2)
    if len(units) < minimum:
        raise FleetTooSmall(
            f"{what} has {len(units)} calibrated unit{'s' if len(units) != 1 else ''}; a population needs at least "
            f"{minimum}: calibrate {minimum - len(units)} more unit{'s' if minimum - len(units) != 1 else ''} of "
            "this model (robots of the same structure document) without a prior first, or calibrate this one "
            "without the prior",
            units=len(units),
            needed=minimum,
        )
    values = np.array(
        [_vector(table, u.values, u.unit, "values") - _vector(table, u.nominal, u.unit, "nominal") for u in units]
    )
    sigmas = np.array([_vector(table, u.std_errors, u.unit, "std_errors") for u in units])
    n = len(table)
    offset, spread, counts = np.full(n, np.nan), np.full(n, np.nan), np.zeros(n, dtype=int)
    excluded = {i for g in EXCLUDED_GROUPS for i in table.groups.get(g, ())}
    for i in range(n):
        known = np.isfinite(values[:, i]) & np.isfinite(sigmas[:, i])
        if i in excluded or known.sum() < minimum:
            continue
        offset[i], spread[i], counts[i] = _population(values[known, i], sigmas[known, i], table.scales[i])
    return FleetPrior(table, offset, spread, counts, tuple(u.unit for u in units))


def _vector(table: ParameterTable, values: Array, unit: str, what: str) -> Array:
    vec = np.asarray(values, dtype=float).reshape(-1)
    if vec.size < len(table):
        raise InvalidInput(f"unit {unit!r}: {vec.size} {what} for a model of {len(table)} parameters", field=what)
    # A version calibrated with model terms carries their parameters after the geometric ones.
    return vec[: len(table)]


def _population(x: Array, sigma: Array, scale: float) -> tuple[float, float, int]:
    """(μ, s, units used) of one parameter's values `x` with their estimation σ."""
    own = float(np.sqrt(np.mean(sigma**2)))
    median = float(np.median(x))
    robust = max(1.4826 * float(np.median(np.abs(x - median))), own, FLOOR * scale)
    kept = x[np.abs(x - median) <= CLIP * robust]
    mu = float(np.mean(kept))
    sd = float(np.std(kept, ddof=1)) if kept.size > 1 else robust
    n = kept.size
    # The predictive spread of a new unit: the mean's uncertainty added, and the variance of Student's t of n − 1
    # degrees of freedom (what a Gaussian prior must carry when the spread itself is estimated from n units).
    t_variance = (n - 1) / (n - 3) if n > 3 else 3.0
    s = max(sd, own, FLOOR * scale) * float(np.sqrt((1.0 + 1.0 / n) * t_variance))
    return mu, s, int(kept.size)


def limits(prior: FleetPrior, alpha: float = OUTLIER_ALPHA) -> Array:
    """(P,) per parameter, the |z| a unit of the population exceeds with probability α / P (NaN: no prior)."""
    covered = list(prior.covered)
    out = np.full(len(prior.table), np.nan)
    if covered:
        dof = np.maximum(prior.counts[covered] - 1, 1).astype(float)
        out[covered] = scipy.special.stdtrit(dof, 1.0 - alpha / (2.0 * len(covered)))
    return out


def compare(prior: FleetPrior, unit: UnitEstimate, *, alpha: float = OUTLIER_ALPHA) -> UnitComparison:
    """`unit` against `prior`, a population it is not part of."""
    table = prior.table
    z = prior.z_scores(
        _vector(table, unit.values, unit.unit, "values"), _vector(table, unit.nominal, unit.unit, "nominal")
    )
    limit = limits(prior, alpha)
    finite = np.isfinite(z)
    if not finite.any():
        return UnitComparison(unit.unit, z, False, None, limit)
    k = int(np.nanargmax(np.abs(np.where(finite, z, np.nan))))
    outlier = bool(np.any(np.abs(z[finite]) > limit[finite]))
    return UnitComparison(unit.unit, z, outlier, (table.names[k], float(z[k])), limit)


def leave_one_out(
    table: ParameterTable, units: Sequence[UnitEstimate], *, minimum: int = MIN_UNITS, alpha: float = OUTLIER_ALPHA
) -> tuple[UnitComparison, ...]:
    """Each unit against the population of the others (empty when the others are fewer than `minimum`)."""
    if len(units) - 1 < minimum:
        return ()
    out = []
    for k, unit in enumerate(units):
        others = [u for j, u in enumerate(units) if j != k]
        out.append(compare(fleet_prior(table, others, minimum=minimum), unit, alpha=alpha))
    return tuple(out)
