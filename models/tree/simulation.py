"""A simulated tree with known errors, and an instrument that measures its tools: the independent truth of the
tree's tests (as `models.simulation` is the chain's)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.engine.runtime import Registry, default_registry
from models.noise import NoiseModel
from models.simulation import instrument_reading, placed_instrument
from models.transforms import matrix_to_rotvec_np
from models.tree.records import ToolRecords
from models.tree.tree import RobotTree


@dataclass(frozen=True)
class SimulatedTree:
    tree: RobotTree
    nominal: Array
    truth: Array
    """The real tree, its base the instrument's frame <- the tree's base."""


def perturbed_tree(
    tree: RobotTree,
    seed: int = 0,
    *,
    tolerances: float = 1.0,
    instrument_distance_mm: float = 3000.0,
    instrument_rotation_deg: float = 30.0,
) -> SimulatedTree:
    """Every parameter but the base off its nominal by a uniform draw within ± `tolerances` of its scale (the
    links, mounts and tools of every branch), and the instrument `instrument_distance_mm` away, turned
    `instrument_rotation_deg` about a random axis."""
    rng = np.random.default_rng(seed)
    table = tree.parameters
    truth = table.nominal + rng.uniform(-tolerances, tolerances, len(table)) * table.scales
    offset, rotation = placed_instrument(rng, instrument_distance_mm, instrument_rotation_deg)
    truth[:6] = np.r_[offset, matrix_to_rotvec_np(rotation)]
    return SimulatedTree(tree, table.nominal, truth)


def measure_tree(
    sim: SimulatedTree,
    tool: str,
    joints: Array,
    *,
    frame: str | None = None,
    noise: NoiseModel | None = None,
    seed: int = 0,
    position_only: bool = True,
    registry: Registry | None = None,
) -> ToolRecords:
    """What an instrument reports of `tool` (in tool `frame`'s frame, or its own) on the true tree."""
    noise = noise or NoiseModel()
    rng = np.random.default_rng(seed)
    exact = ToolRecords(tool, joints, np.zeros((joints.shape[0], 3)), frame=frame)
    poses = exact.model(sim.tree, sim.truth, registry or default_registry(), jacobian=False)
    positions, quats = instrument_reading(rng, poses.positions, poses.rotations, noise, position_only=position_only)
    return ToolRecords(tool, joints, positions, quats, frame=frame)
