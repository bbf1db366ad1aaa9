"""A fleet's population and one unit against it, in boundary units (mm, degrees)."""

from __future__ import annotations

import numpy as np

from models._types import Array
from models.evaluation.fleet import FleetPrior, UnitComparison
from service.schemas.fleets import FleetParameterPublic, FleetZPublic


def population_out(population: FleetPrior) -> list[FleetParameterPublic]:
    """Per parameter with a prior: the mean deviation from nominal and the spread."""
    table = population.table
    return [
        FleetParameterPublic(
            name=table.names[i],
            unit=table.units[i],  # type: ignore[arg-type]  # the table's units are the contract's
            mean_offset=float(population.offset[i] * table.to_boundary[i]),
            spread=float(population.spread[i] * table.to_boundary[i]),
            units=int(population.counts[i]),
        )
        for i in population.covered
    ]


def comparison_rows_out(
    population: FleetPrior, found: UnitComparison, values: Array, nominal: Array, estimated: list[int]
) -> list[FleetZPublic]:
    """The estimated parameters the population covers: this unit's deviation, the population's, z, the limit."""
    table = population.table
    rows = []
    for i in estimated:
        z = float(found.z[i])
        if not np.isfinite(z):
            continue
        k = float(table.to_boundary[i])
        rows.append(
            FleetZPublic(
                name=table.names[i],
                unit=table.units[i],  # type: ignore[arg-type]
                offset=float(values[i] - nominal[i]) * k,
                mean_offset=float(population.offset[i]) * k,
                spread=float(population.spread[i]) * k,
                z=z,
                limit=float(found.limit[i]),
                flagged=bool(abs(z) > found.limit[i]),
            )
        )
    return rows
