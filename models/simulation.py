"""Simulated robots with known errors, and simulated instruments that measure them.

The independent truth for tests, benchmarks and examples: a "true" robot is
the nominal one perturbed by known amounts, seen by an instrument placed far
away at an unknown rotation, with Gaussian noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.error_analysis.magnitudes import ErrorMagnitudes
from models.kinematics import forward_kinematics
from models.noise import NoiseModel
from models.robot import RobotDescription
from models.terms import Conditions
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
    base_rot = rotvec_to_matrix_np(_random_unit(rng) * np.radians(instrument_rotation_deg))
    # The instrument sees the robot base from `distance` away; the base transform is world <- {0}.
    base_rot = base_rot @ rotvec_to_matrix_np(nominal[s_base][3:])
    truth[s_base] = np.r_[_random_unit(rng) * instrument_distance_mm, matrix_to_rotvec_np(base_rot)]
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
    n = joints.shape[0]
    positions = fk.positions + rng.normal(scale=noise.position_mm, size=(n, 3))
    if position_only:
        return Campaign(np.array(joints, dtype=float), positions, None, conditions=conditions)
    tilt = rotvec_to_matrix_np(rng.normal(scale=noise.orientation_rad, size=(n, 3)))
    quats = matrix_to_quaternion(tilt @ fk.rotations)
    return Campaign(np.array(joints, dtype=float), positions, quats, conditions=conditions)


def fleet_unit(
    desc: RobotDescription, unit: int, *, fleet_seed: int = 0, systematic: float = 1.0, spread: float = 0.05
) -> SimulatedRobot:
    """Unit `unit` of a fleet of identical cells (one arm model, one tool model): every parameter but the base is
    nominal + the model's systematic deviation (Gaussian, `systematic` × the parameter's scale, drawn once per
    `fleet_seed`: every unit shares it) + the unit's own (Gaussian, `spread` × scale). The base, the instrument
    3 m away and rotated, is drawn per unit as in `perturbed_robot`."""
    table = desc.parameters
    own = [i for i in range(len(table)) if table.specs[i].group != "base"]
    common = np.random.default_rng([fleet_seed, 0]).normal(size=len(table)) * systematic * table.scales
    mine = np.random.default_rng([fleet_seed, 1, unit]).normal(size=len(table)) * spread * table.scales
    placed = perturbed_robot(desc, seed=int(np.random.default_rng([fleet_seed, 2, unit]).integers(2**31)))
    truth = placed.truth.copy()
    truth[own] = table.nominal[own] + common[own] + mine[own]
    return SimulatedRobot(desc, placed.nominal, truth)
