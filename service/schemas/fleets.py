"""A fleet: the robots of one structure document, their population per parameter, and one unit against it
(boundary units: mm, degrees)."""

from __future__ import annotations

from pydantic import Field

from service.schemas.common import PARAMETER_UNITS, OptionalFloat, Public, optional

FLEET_KEY = r"^[0-9a-f]{16}$"


class FleetParameterPublic(Public):
    name: str
    unit: PARAMETER_UNITS
    mean_offset: float = Field(description="The population's mean deviation from the nominal value")
    spread: float = Field(
        description="Its spread (one standard deviation) for a new unit: the units' scatter, never below their own "
        "standard errors, widened for the few units it comes from"
    )
    units: int = Field(description="Calibrated units behind it (after the robust estimate left any out)")


class FleetUnitPublic(Public):
    robot_id: str
    name: str
    version: int = Field(description="Its current parameter version")
    calibrated: bool = Field(
        description="Its current version comes from a calibration made without a prior: it counts in the population"
    )
    outlier: bool | None = Field(
        description="Off the population of the other calibrated units (leave-one-out); null when they are too few "
        "or the unit is not calibrated"
    )
    worst_parameter: str | None = optional("Its parameter farthest off the others'")
    worst_z: OptionalFloat = optional("How many spreads off it is")


class FleetPublic(Public):
    """The fleet of robots sharing a structure document (their base and tool guesses aside)."""

    fleet: str = Field(description="The fleet's key: a digest of the structure document", pattern=FLEET_KEY)
    units: list[FleetUnitPublic] = Field(description="Every robot of the fleet, oldest first")
    calibrated: int = Field(description="Units whose current version is a calibration without a prior")
    needed: int = Field(description="Calibrated units a population (and a calibration with `prior: fleet`) needs")
    ready: bool = Field(description="A population is estimated: calibrated ≥ needed")
    parameters: list[FleetParameterPublic] = Field(
        description="The population per parameter (the base, each campaign's instrument frame, has none); empty "
        "until the fleet is ready"
    )
    outliers: list[str] = Field(description="The robot ids of the units flagged as outliers")


class FleetZPublic(Public):
    name: str
    unit: PARAMETER_UNITS
    offset: float = Field(description="This calibration's value minus its nominal value")
    mean_offset: float = Field(description="The fleet's mean deviation")
    spread: float
    z: float = Field(description="(offset − mean_offset) / spread")
    limit: float = Field(description="|z| beyond which a unit of the population is flagged")
    flagged: bool


class FleetComparisonPublic(Public):
    """This calibration against the population of the other calibrated units of its fleet."""

    fleet: str = Field(pattern=FLEET_KEY)
    units: int = Field(description="The other calibrated units the population comes from")
    prior_used: bool = Field(description="The fit used this population as its prior (MAP, options.prior fleet)")
    outlier: bool = Field(description="Some parameter lies beyond its limit: this unit is not like the others")
    parameters: list[FleetZPublic] = Field(description="The estimated parameters the population covers")
