"""Simulated robots with known errors, and simulated instruments that measure them.

The independent truth for tests, benchmarks and examples: a "true" robot is
the nominal one perturbed by known amounts, seen by an instrument placed far
away at an unknown rotation, with Gaussian noise.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from fnmatch import fnmatchcase

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.description.parameters import GROUP_ALIASES
from models.description.robot import RobotDescription
from models.description.terms import Conditions
from models.error_analysis.magnitudes import ErrorMagnitudes
from models.errors import InvalidInput
from models.kinematics import forward_kinematics
from models.noise import NoiseModel
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, rotvec_to_matrix_np


@dataclass(frozen=True)
class SimulatedRobot:
    desc: RobotDescription
    nominal: Array
    """What the user believes (internal units): the description's nominal values."""
    truth: Array
    """The real robot, including the instrument frame as its base transform."""


def _random_unit(rng: np.random.Generator) -> Array:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def placed_instrument(rng: np.random.Generator, distance_mm: float, rotation_deg: float) -> tuple[Array, Array]:
    """Where a simulated instrument sees the robot's (or tree's) base from: (the offset, `distance_mm` along a
    random direction; the rotation, `rotation_deg` about a random axis), the axis drawn first."""
    rotation = rotvec_to_matrix_np(_random_unit(rng) * np.radians(rotation_deg))
    return _random_unit(rng) * distance_mm, rotation


def instrument_reading(
    rng: np.random.Generator, positions: Array, rotations: Array, noise: NoiseModel, *, position_only: bool
) -> tuple[Array, Array | None]:
    """What an instrument reports of true poses: the positions with its Gaussian noise, then (unless
    `position_only`: None) the orientations turned by a random small rotation of its angular σ, as quaternions."""
    measured = positions + rng.normal(scale=noise.position_mm, size=positions.shape)
    if position_only:
        return measured, None
    tilt = rotvec_to_matrix_np(rng.normal(scale=noise.orientation_rad, size=(positions.shape[0], 3)))
    return measured, matrix_to_quaternion(tilt @ rotations)


def thesis_perturbation(desc: RobotDescription, rng: np.random.Generator, errors: ErrorMagnitudes) -> Array:
    """Uniform errors within ± the thesis magnitudes on every DH number, a_i, b_i and leg offset."""
    size = errors.vector(desc)
    # One draw per carriage and hexapod parameter, in table order (one double each, as the scalar draws
    # of earlier versions took): the seeds of the tests and benchmarks keep their robots.
    drawn = np.array(desc.parameters.indices(("carriage", "hexapod")), dtype=int)
    delta = np.zeros(desc.n_params)
    delta[drawn] = rng.uniform(-size[drawn], size[drawn])
    return delta


def perturbed_robot(
    desc: RobotDescription,
    seed: int = 0,
    *,
    errors: ErrorMagnitudes = ErrorMagnitudes(),
    tool_error_mm: float = 0.5,
    tool_error_deg: float = 0.2,
    instrument_distance_mm: float = 3000.0,
    instrument_rotation_deg: float = 30.0,
) -> SimulatedRobot:
    """A true robot: thesis-sized geometric errors, a tool off by the given amounts, and the
    instrument `instrument_distance_mm` away, rotated `instrument_rotation_deg` about a random axis."""
    rng = np.random.default_rng(seed)
    table = desc.parameters
    nominal = table.nominal
    truth = nominal + thesis_perturbation(desc, rng, errors)
    s_base, s_tool = desc.slices["base"], desc.slices["tool"]
    offset, base_rot = placed_instrument(rng, instrument_distance_mm, instrument_rotation_deg)
    # The instrument sees the robot base from `distance` away; the base transform is world <- {0}.
    base_rot = base_rot @ rotvec_to_matrix_np(nominal[s_base][3:])
    truth[s_base] = np.r_[offset, matrix_to_rotvec_np(base_rot)]
    tool_rot = rotvec_to_matrix_np(nominal[s_tool][3:]) @ rotvec_to_matrix_np(
        _random_unit(rng) * np.radians(tool_error_deg)
    )
    truth[s_tool] = np.r_[nominal[s_tool][:3] + _random_unit(rng) * tool_error_mm, matrix_to_rotvec_np(tool_rot)]
    return SimulatedRobot(desc, nominal, truth)


def measure(
    robot: SimulatedRobot,
    joints: Array,
    noise: NoiseModel | None = None,
    seed: int = 0,
    *,
    position_only: bool = False,
    conditions: Conditions | None = None,
) -> Campaign:
    """What the instrument reports for the true robot at these joints, with Gaussian noise.

    `conditions` (temperatures, payloads) are what the records were measured under: the truth's model terms
    act on them, and the campaign carries them, as a real one does."""
    noise = noise or NoiseModel()
    rng = np.random.default_rng(seed)
    fk = forward_kinematics(robot.desc, joints, robot.truth, conditions=conditions)
    positions, quats = instrument_reading(rng, fk.positions, fk.rotations, noise, position_only=position_only)
    return Campaign(np.array(joints, dtype=float), positions, quats, conditions=conditions)


def unit_spreads(desc: RobotDescription, spread: float, spreads: Mapping[str, float] | None = None) -> Array:
    """Each parameter's unit-to-unit spread in fractions of its scale (`fleet_unit`): `spread` everywhere, but
    where a key of `spreads` names the parameter. A key is a group (`links`, `tool`; `table.indices`' names and
    aliases), a parameter name, or a name pattern (`fnmatch`: `link*.theta`, the joint zero offsets). Names and
    patterns win over groups, so that `{"links": 0.05, "link*.theta": 1.0}` reads as "the machined geometry
    alike, the offsets not"; two names or patterns that give one parameter different spreads are refused, as
    is a key that matches nothing or only the base (the base is the instrument's placement, drawn per unit
    anyway), and a negative spread. The base's entries are 0."""
    table = desc.parameters
    out = np.full(len(table), float(spread))
    base = set(table.groups.get("base", ()))
    by_name: dict[int, tuple[str, float]] = {}
    for key, value in (spreads or {}).items():
        if not value >= 0.0:
            raise InvalidInput(
                f"a unit spread must be >= 0 (of a tolerance); {key!r} has {value}", field="spreads", value=value
            )
        is_group = key in table.groups or key in GROUP_ALIASES
        if is_group or key in table.index:
            hit = set(table.indices([key]))
        else:
            hit = {i for i, name in enumerate(table.names) if fnmatchcase(name, key)}
        if not hit - base:
            raise InvalidInput(
                f"{key!r} names no parameter that differs from unit to unit (the base is drawn per unit); "
                f"groups are {sorted(set(table.groups) - {'base'})}",
                field="spreads",
                value=key,
            )
        for i in hit - base:
            if is_group:
                continue
            if i in by_name and by_name[i][1] != value:
                raise InvalidInput(
                    f"{table.names[i]} has two unit spreads: {by_name[i][1]} ({by_name[i][0]!r}) and {value} ({key!r})",
                    field="spreads",
                    value=key,
                )
            by_name[i] = (key, float(value))
        if is_group:
            out[sorted(hit - base)] = value
    # Groups first (whatever their order in the mapping), then the names and patterns over them.
    for i, (_, value) in by_name.items():
        out[i] = value
    out[sorted(base)] = 0.0
    return out


def fleet_unit(
    desc: RobotDescription,
    unit: int,
    *,
    fleet_seed: int = 0,
    systematic: float = 1.0,
    spread: float = 0.05,
    spreads: Mapping[str, float] | None = None,
) -> SimulatedRobot:
    """Unit `unit` of a fleet of identical cells (one arm model, one tool model): every parameter but the base is
    nominal + the model's systematic deviation (Gaussian, `systematic` × the parameter's scale, drawn once per
    `fleet_seed`: every unit shares it) + the unit's own (Gaussian, `spread` × scale). The base, the instrument
    3 m away and rotated, is drawn per unit as in `perturbed_robot`.

    `spreads` gives kinds of parameters their own unit spread (`unit_spreads`): real units of one model are not
    alike to the same fraction everywhere. Machined geometry (lengths, twists: one drawing, one fixture) repeats
    closely; what assembly sets (the joints' zero offsets from encoder mastering, the tool's mounting) differs
    by much of its tolerance, e.g. `{"links": 0.05, "link*.theta": 1.0, "tool": 1.0}`. The same random numbers
    are drawn either way: a unit's deviation is the same standard normal draw, scaled by its parameter's spread,
    so without `spreads` the units are those of earlier versions, bit for bit."""
    table = desc.parameters
    own = [i for i in range(len(table)) if table.specs[i].group != "base"]
    common = np.random.default_rng([fleet_seed, 0]).normal(size=len(table)) * systematic * table.scales
    fraction: float | Array = spread if spreads is None else unit_spreads(desc, spread, spreads)
    mine = np.random.default_rng([fleet_seed, 1, unit]).normal(size=len(table)) * fraction * table.scales
    placed = perturbed_robot(desc, seed=int(np.random.default_rng([fleet_seed, 2, unit]).integers(2**31)))
    truth = placed.truth.copy()
    truth[own] = table.nominal[own] + common[own] + mine[own]
    return SimulatedRobot(desc, placed.nominal, truth)
