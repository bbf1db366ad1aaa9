"""Fleets: the robots of one structure document, read from the stored robots and their current versions (no
table of their own). A unit counts in its fleet's population when its current version is a calibration made
without a prior (a unit calibrated with the fleet's prior would vote twice for the fleet's own mean)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sqlalchemy.orm import Session

from models import RobotDescription
from models._types import Array
from models.errors import PriorMismatch
from models.evaluation.fleet import MIN_UNITS, FleetPrior, UnitEstimate, compare, fleet_prior, leave_one_out
from models.identification import IdentificationResult
from models.identification.prior import ParameterPrior
from service.conversions.fleets import comparison_rows_out, population_out
from service.conversions.robots import description, pose6
from service.errors import NotFound
from service.persistence import Database, Repository
from service.persistence.tables import ParameterVersion, Robot
from service.schemas.fleets import (
    FleetComparisonPublic,
    FleetPublic,
    FleetUnitPublic,
)


@dataclass(frozen=True)
class Member:
    robot: Robot
    version: ParameterVersion
    unit: UnitEstimate | None
    """Its calibrated values (the geometric ones), None where its current version does not count."""


@dataclass(frozen=True)
class Fleet:
    key: str
    desc: RobotDescription
    """The geometric model of the robot the fleet was read for (every member's table has its names)."""
    members: tuple[Member, ...]

    @property
    def units(self) -> tuple[UnitEstimate, ...]:
        return tuple(m.unit for m in self.members if m.unit is not None)

    def population(self, *, without: str | None = None) -> FleetPrior:
        """The population of the calibrated units but `without`; FleetTooSmall (a 422) below MIN_UNITS."""
        units = [u for u in self.units if u.unit != without]
        what = f"fleet {self.key}" + (", this robot aside," if without is not None else "")
        return fleet_prior(self.desc.parameters, units, what=what)


def read_fleet(s: Session, robot: Robot) -> Fleet:
    """The fleet of `robot`, inside the caller's transaction (two queries, whatever the fleet's size)."""
    repo = Repository(s)
    key = robot.fleet_key
    rows = repo.current_versions(key)
    with_prior = repo.calibrations_with_prior(
        [v.calibration_id for _, v in rows if v.provenance == "calibration" and v.calibration_id is not None]
    )
    desc = description(robot).geometric
    members = tuple(_member(desc, other, version, with_prior) for other, version in rows)
    return Fleet(key, desc, members)


def _member(fleet: RobotDescription, robot: Robot, row: ParameterVersion, with_prior: dict[str, bool]) -> Member:
    made_with_prior = with_prior.get(row.calibration_id or "")
    if row.provenance != "calibration" or made_with_prior is None or made_with_prior:
        return Member(robot, row, None)
    table = fleet.parameters
    n = len(table)
    # The fleet's nominal values with this robot's own base and tool guesses (what its description holds).
    nominal = table.nominal
    nominal[fleet.slices["base"]] = pose6(robot.base)
    nominal[fleet.slices["tool"]] = pose6(robot.tool)
    values = np.asarray(row.values[:n], dtype=float)
    # The standard errors of what a calibration estimated (flagged identifiable); NaN for what it held.
    std = np.full(n, np.nan)
    for i, (value, estimated) in enumerate(zip(row.std_errors or [], row.identifiable or [], strict=False)):
        if i < n and estimated and value is not None:
            std[i] = float(value)
    return Member(robot, row, UnitEstimate(robot.id, values, std, nominal))


def get_fleet(*, db: Database, robot_id: str) -> FleetPublic:
    with db.reader() as s:
        return fleet_out(read_fleet(s, Repository(s).robot(robot_id)))


def get_fleet_by_key(*, db: Database, key: str) -> FleetPublic:
    with db.reader() as s:
        members = Repository(s).current_versions(key)
        if not members:
            raise NotFound(f"no robot belongs to fleet {key!r}", resource="fleet")
        return fleet_out(read_fleet(s, members[0][0]))


def fleet_out(fleet: Fleet) -> FleetPublic:
    table = fleet.desc.parameters
    units = fleet.units
    ready = len(units) >= MIN_UNITS
    parameters = population_out(fleet.population()) if ready else []
    flags = {c.unit: c for c in leave_one_out(table, units)}
    out_units = []
    for m in fleet.members:
        c = flags.get(m.robot.id)
        out_units.append(
            FleetUnitPublic(
                robot_id=m.robot.id,
                name=m.robot.name,
                version=m.version.version,
                calibrated=m.unit is not None,
                outlier=None if c is None else c.outlier,
                worst_parameter=None if c is None or c.worst is None else c.worst[0],
                worst_z=None if c is None or c.worst is None else c.worst[1],
            )
        )
    return FleetPublic(
        fleet=fleet.key,
        units=out_units,
        calibrated=len(units),
        needed=MIN_UNITS,
        ready=ready,
        parameters=parameters,
        outliers=[u for u, c in flags.items() if c.outlier],
    )


def calibration_prior(fleet: Fleet, robot_id: str, desc: RobotDescription, expected: str | None) -> ParameterPrior:
    """The prior of a calibration of robot `robot_id` (its model `desc`, with any terms) from its fleet, itself
    excluded: PriorMismatch when `expected` names another fleet, FleetTooSmall while the others are too few."""
    if expected is not None and expected != fleet.key:
        raise PriorMismatch(
            f"options.fleet is {expected}, but robot {robot_id!r} belongs to fleet {fleet.key} (robots of another "
            "structure document): calibrate it with its own fleet's prior (leave out options.fleet), or without one",
            expected=fleet.key,
            got=expected,
        )
    population = fleet.population(without=robot_id)
    n, total = len(population.table), desc.n_params
    mean, spread = np.full(total, np.nan), np.full(total, np.nan)
    mean[:n] = desc.parameters.nominal[:n] + population.offset
    spread[:n] = population.spread
    return ParameterPrior(tuple(desc.parameters.names), mean, spread)


def comparison_out(
    fleet: Fleet, robot_id: str, nominal: Array, result: IdentificationResult, *, prior_used: bool
) -> FleetComparisonPublic | None:
    """This calibration (of robot `robot_id`, its geometric `nominal` values) against the others' population
    (None while they are too few, or when it failed)."""
    if len(fleet.units) - any(u.unit == robot_id for u in fleet.units) < MIN_UNITS or not result.succeeded:
        return None
    population = fleet.population(without=robot_id)
    table = population.table
    n = len(table)
    std = np.full(n, np.nan)
    estimated = [i for i in result.estimated if i < n]
    std[estimated] = result.std_errors[estimated]
    unit = UnitEstimate(robot_id, result.parameters[:n], std, nominal)
    found = compare(population, unit)
    rows = comparison_rows_out(population, found, result.parameters, nominal, estimated)
    return FleetComparisonPublic(
        fleet=fleet.key,
        units=len(population.units),
        prior_used=prior_used,
        outlier=any(r.flagged for r in rows),
        parameters=rows,
    )
