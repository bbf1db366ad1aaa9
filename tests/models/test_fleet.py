"""A fleet's population (models.evaluation.fleet): robust, never overconfident, outliers flagged, too few units refused.

The units here are synthetic estimates drawn from a known population (a value per unit, plus its estimation
noise of known σ), so that the population's truth is known exactly; the whole chain through simulated
calibrations is `benchmarks/bench_fleet.py` and the service's tests."""

from __future__ import annotations

import numpy as np
import pytest

from models.description.examples import ur5_like
from models.errors import FleetTooSmall, InvalidInput
from models.evaluation.fleet import MIN_UNITS, UnitEstimate, compare, fleet_prior, leave_one_out
from optimal_design.problem import DesignInputs, DesignProblem, prior_information

DESC = ur5_like()
TABLE = DESC.parameters
N = len(TABLE)
TAU = 0.02 * TABLE.scales
"""The population's true spread per parameter."""
SIGMA = 0.01 * TABLE.scales
"""Each unit's estimation σ."""


def _units(count: int, seed: int, *, mu: np.ndarray | None = None) -> list[UnitEstimate]:
    rng = np.random.default_rng(seed)
    mean = TABLE.nominal + (TABLE.scales if mu is None else mu)
    out = []
    for k in range(count):
        truth = mean + TAU * rng.normal(size=N)
        out.append(UnitEstimate(f"u{k}", truth + SIGMA * rng.normal(size=N), SIGMA.copy(), TABLE.nominal))
    return out


def test_the_population_is_estimated_and_covers_new_units() -> None:
    """Over 40 fleets of 10, the spread is √(τ² + σ²)-sized and a new unit's estimate lies within 2 spreads of
    the population in ~95 % of its parameters (the predictive spread, mean uncertainty included)."""
    inside, ratio = [], []
    for seed in range(40):
        units = _units(11, seed)
        population = fleet_prior(TABLE, units[:10])
        z = population.z_scores(units[10].values, TABLE.nominal)[list(population.covered)]
        inside.append(np.mean(np.abs(z) <= 2.0))
        covered = list(population.covered)
        ratio.append(np.median(population.spread[covered] / np.hypot(TAU, SIGMA)[covered]))
    assert 0.92 <= float(np.mean(inside)) <= 0.99
    assert 1.0 <= float(np.median(ratio)) <= 1.35


def test_the_base_gets_no_prior_and_the_rest_does() -> None:
    population = fleet_prior(TABLE, _units(6, 1))
    base = set(TABLE.groups["base"])
    assert set(population.covered) == set(range(N)) - base
    prior = population.prior()
    assert np.all(np.isnan(prior.mean[list(base)]))
    np.testing.assert_allclose(
        population.precision()[list(population.covered)], population.spread[list(population.covered)] ** -2
    )


def test_one_wild_unit_does_not_move_the_population_and_is_flagged() -> None:
    """A unit 30 spreads off in one parameter: the mean stays where the others are, the unit is flagged with
    that parameter, and no other unit is."""
    units = _units(10, 3)
    i = TABLE.index["link3.a"]
    wild = units[4].values.copy()
    wild[i] += 30 * float(np.hypot(TAU[i], SIGMA[i]))
    units[4] = UnitEstimate("u4", wild, SIGMA.copy(), TABLE.nominal)
    clean = fleet_prior(TABLE, [u for k, u in enumerate(units) if k != 4])
    robust = fleet_prior(TABLE, units)
    assert abs(robust.offset[i] - clean.offset[i]) < 0.5 * clean.spread[i]
    flags = leave_one_out(TABLE, units)
    assert [c.unit for c in flags if c.outlier] == ["u4"]
    worst = next(c for c in flags if c.unit == "u4").worst
    assert worst is not None and worst[0] == "link3.a" and worst[1] > 10


@pytest.mark.slow  # 80 leave-one-out populations: ~0.4 s
def test_no_false_flags_in_clean_fleets() -> None:
    """80 units (8 fleets of 10) drawn from one population: at most a few flagged (1 % a unit stated; measured
    0 of 80, and 1 of 200 over 20 fleets)."""
    flagged = sum(c.outlier for seed in range(8) for c in leave_one_out(TABLE, _units(10, 100 + seed)))
    assert flagged <= 3


def test_the_spread_is_never_below_the_units_own_sigma() -> None:
    """Units that agree exactly (no population spread, no noise in their values) but report σ: the spread is σ
    widened for the mean's and the spread's uncertainty (6 units: (1 + 1/6) · 5/3), not zero."""
    units = [UnitEstimate(f"u{k}", TABLE.nominal + TABLE.scales, SIGMA.copy(), TABLE.nominal) for k in range(6)]
    population = fleet_prior(TABLE, units)
    covered = list(population.covered)
    np.testing.assert_allclose(population.spread[covered], SIGMA[covered] * np.sqrt((1 + 1 / 6) * 5 / 3))
    np.testing.assert_allclose(population.offset[covered], TABLE.scales[covered])


def test_the_prior_follows_each_units_own_nominal() -> None:
    """A unit with another tool guess gets the fleet's mean deviation on its own guess."""
    population = fleet_prior(TABLE, _units(6, 2))
    other = TABLE.nominal.copy()
    other[TABLE.index["tool.z"]] += 50.0
    prior = population.prior(other)
    i = TABLE.index["tool.z"]
    assert prior.mean[i] == pytest.approx(other[i] + population.offset[i])


@pytest.mark.parametrize("count", [0, 1, MIN_UNITS - 1])
def test_too_few_units_are_refused_with_what_to_do(count: int) -> None:
    with pytest.raises(FleetTooSmall) as caught:
        fleet_prior(TABLE, _units(count, 4))
    assert caught.value.units == count and caught.value.needed == MIN_UNITS
    assert f"calibrate {MIN_UNITS - count} more" in str(caught.value)
    assert leave_one_out(TABLE, _units(count, 4)) == ()


def test_a_unit_of_another_model_is_refused() -> None:
    short = UnitEstimate("x", np.zeros(N - 3), np.zeros(N - 3), np.zeros(N - 3))
    with pytest.raises(InvalidInput, match="for a model of"):
        fleet_prior(TABLE, [*_units(5, 5), short])


def test_compare_names_the_worst_parameter() -> None:
    units = _units(8, 6)
    population = fleet_prior(TABLE, units[:7])
    result = compare(population, units[7])
    assert result.worst is not None and not result.outlier
    z = population.z_scores(units[7].values, TABLE.nominal)
    assert abs(result.worst[1]) == pytest.approx(np.nanmax(np.abs(z)))


def test_the_design_adds_the_prior_information_to_the_fixed_poses() -> None:
    """The design problem's `base` with a prior is the one without plus diag(scale²/s²) on the covered
    parameters of the identifiable subset (the rows MAP stacks)."""
    population = fleet_prior(TABLE, _units(6, 7))
    plain = DesignProblem.build(DESC, DesignInputs(candidate_count=30, seed=1))
    with_prior = DesignProblem.build(DESC, DesignInputs(candidate_count=30, seed=1, prior=population.prior()))
    free = plain.info.free
    expected = np.zeros(len(free))
    for k, i in enumerate(free):
        if i in population.covered:
            expected[k] = (TABLE.scales[i] / population.spread[i]) ** 2
    np.testing.assert_allclose(with_prior.base - plain.base, np.diag(expected))
    np.testing.assert_allclose(prior_information(DESC, population.prior(), free), np.diag(expected))
