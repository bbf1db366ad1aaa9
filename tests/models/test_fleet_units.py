"""Simulated fleets (models.simulation.fleet_unit): per-kind unit scatter as asked, the default unchanged.

The truth for the statistics is the request itself: over many units of one fleet, each parameter's deviation
from the fleet's mean is the unit's own draw, so its standard deviation over the units, in scales, must be the
spread asked for that parameter, within the sampling error of a standard deviation (1/√(2n) relative)."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from models.description.examples import ur5_like
from models.errors import InvalidInput
from models.simulation import fleet_unit, unit_spreads

DESC = ur5_like()
TABLE = DESC.parameters
BASE = list(TABLE.groups["base"])
OWN = [i for i in range(len(TABLE)) if i not in BASE]
OFFSETS = [TABLE.index[f"link{j}.theta"] for j in range(1, 7)]
MACHINED = [i for i in TABLE.groups["links"] if i not in OFFSETS]
TOOL = list(TABLE.groups["tool"])
ASSEMBLY = {"links": 0.03, "link*.theta": 1.0, "tool": 0.5}


def _digest(truth: np.ndarray) -> str:
    # The non-base entries are nominal + Gaussian draws × scale, exact in IEEE arithmetic on any platform (the
    # base goes through trigonometry, whose last bit is the C library's).
    return hashlib.sha256(np.ascontiguousarray(truth[OWN]).tobytes()).hexdigest()


@pytest.mark.parametrize(
    ("unit", "fleet_seed", "systematic", "spread", "digest"),
    [
        # SHA-256 of the units `fleet_unit` drew before `spreads` existed (main at a40bddb; 0, 1.0 and 0.05 are
        # the defaults).
        (3, 0, 1.0, 0.05, "e3da54e12f8c6257ef1d0d7a452284eaca25157d16ef46245fe7afa8364d1760"),
        (97, 0, 1.0, 0.01, "24a0fb5a473a0a49aa777c5206dcea87d69e458836eaa91d427a844783679329"),
        (5, 4, 0.5, 0.3, "f9a0dd79ff13f0d345e1294d106ab20b49a8011935f345cc2063fa95b002b164"),
    ],
)
def test_the_default_units_are_those_of_before_bit_for_bit(
    unit: int, fleet_seed: int, systematic: float, spread: float, digest: str
) -> None:
    if (fleet_seed, systematic, spread) == (0, 1.0, 0.05):
        assert _digest(fleet_unit(DESC, unit).truth) == digest  # every default
    before = fleet_unit(DESC, unit, fleet_seed=fleet_seed, systematic=systematic, spread=spread).truth
    assert _digest(before) == digest
    # A mapping that gives every group the common spread is the same fleet, to the bit, base included.
    same = fleet_unit(
        DESC,
        unit,
        fleet_seed=fleet_seed,
        systematic=systematic,
        spread=spread,
        spreads={"links": spread, "tool": spread},
    )
    np.testing.assert_array_equal(same.truth, before)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_each_kind_scatters_by_its_own_spread_over_many_units() -> None:
    n = 1500
    truths = np.array([fleet_unit(DESC, k, fleet_seed=11, spread=0.2, spreads=ASSEMBLY).truth for k in range(n)])
    # Unit-to-unit scatter in scales; ddof=1: the fleet's mean (nominal + systematic) is estimated from the units.
    scatter = truths.std(axis=0, ddof=1) / TABLE.scales
    for indices, wanted in ((OFFSETS, 1.0), (MACHINED, 0.03), (TOOL, 0.5)):
        # Per parameter: within 4 standard errors of a standard deviation of n draws.
        np.testing.assert_allclose(scatter[indices], wanted, rtol=4 / np.sqrt(2 * n))
        # Pooled over the kind: the same within its tighter error.
        pooled = np.sqrt(np.mean(scatter[indices] ** 2))
        assert abs(pooled / wanted - 1) < 4 / np.sqrt(2 * n * len(indices))
    # The fleet's mean is the shared systematic deviation, the same whatever the units' spreads: the mean over
    # the units sits on it within its standard error (spread / √n), on the scatter-free fleet's value.
    shared = fleet_unit(DESC, 0, fleet_seed=11, spread=0.0).truth
    deviation = (truths.mean(axis=0) - shared)[OWN] / TABLE.scales[OWN]
    assert np.all(np.abs(deviation) < 4 * unit_spreads(DESC, 0.2, ASSEMBLY)[OWN] / np.sqrt(n))


def test_the_spread_vector_reads_groups_then_names() -> None:
    fractions = unit_spreads(DESC, 0.2, {"link*.theta": 1.0, "links": 0.03, "tool.rz": 0.0})
    np.testing.assert_array_equal(fractions[OFFSETS], 1.0)  # the pattern wins over the group, in either order
    np.testing.assert_array_equal(fractions[MACHINED], 0.03)
    np.testing.assert_array_equal(fractions[TOOL], [0.2] * 5 + [0.0])  # not named: the common spread
    np.testing.assert_array_equal(fractions[BASE], 0.0)
    # The IWR's name of the links group is accepted for every robot.
    np.testing.assert_array_equal(unit_spreads(DESC, 0.2, {"carriage": 0.03}), unit_spreads(DESC, 0.2, {"links": 0.03}))


@pytest.mark.parametrize(
    "spreads",
    [
        {"base": 1.0},  # the base is the instrument's placement, drawn per unit
        {"link*.offset": 1.0},  # matches nothing
        {"links": -0.1},
        {"links": float("nan")},
        {"link*.theta": 1.0, "link2.*": 0.5},  # link2.theta would get two spreads
    ],
)
def test_unusable_spreads_are_refused(spreads: dict[str, float]) -> None:
    with pytest.raises(InvalidInput):
        fleet_unit(DESC, 0, spreads=spreads)
