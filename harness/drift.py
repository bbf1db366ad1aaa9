"""A simulated drift-aware campaign: a reference pose every few records, an instrument frame that creeps
linearly over the campaign, and the same records without the drift (the truth the tests and the benchmark
compare against)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from models import RobotDescription, sample_workspace
from models._types import Array
from models.campaign import Campaign
from models.identification.drift import Timeline
from models.kinematics import forward_kinematics
from models.noise import NoiseModel
from models.simulation import SimulatedRobot, measure, perturbed_robot


@dataclass(frozen=True)
class DriftCampaign:
    robot: SimulatedRobot
    drifted: Campaign
    clean: Campaign
    """The same records measured by an instrument that did not drift (same noise draw)."""
    timeline: Timeline
    drift_mm: Array
    """(N, 3) the drift each record carries (zero at the campaign's middle)."""


def drift_campaign(
    desc: RobotDescription,
    seed: int,
    *,
    records: int = 60,
    every: int = 6,
    drift_um: float = 30.0,
    noise: NoiseModel,
    seconds_per_record: float = 60.0,
) -> DriftCampaign:
    """`records` records (the reference pose at 0, every, 2·every …, the rest random workspace poses in a
    sweep along the first joint, as a campaign run across the cell is), measured with `noise`; the instrument
    frame moves `drift_um` along a random direction, linearly from the first record to the last."""
    robot = perturbed_robot(desc, seed=seed)
    rng = np.random.default_rng(seed + 1000)
    poses = sample_workspace(desc, records + 1, seed=seed + 2000)
    reference, others = poses[0], poses[1:]
    is_reference = np.arange(records) % every == 0
    others = others[np.argsort(others[:, 0], kind="stable")][: int((~is_reference).sum())]
    joints = np.empty((records, desc.n_joints))
    joints[is_reference] = reference
    joints[~is_reference] = others
    clean = measure(robot, joints, noise, seed=seed + 3000)
    times = np.arange(records, dtype=np.float64) * seconds_per_record
    direction = rng.normal(size=3)
    direction /= np.linalg.norm(direction)
    fraction = (times - times.mean()) / (times[-1] - times[0])  # −½ … ½: zero at the middle
    drift = fraction[:, None] * (drift_um * 1e-3) * direction[None, :]
    drifted = replace(clean, positions=clean.positions + drift)
    timeline = Timeline(times_s=times, reference=np.flatnonzero(is_reference).astype(np.intp))
    return DriftCampaign(robot, drifted, clean, timeline, drift)


def tcp_error_mm(desc: RobotDescription, robot: SimulatedRobot, theta: Array, joints: Array) -> float:
    """RMS TCP position error of `theta` against the truth at `joints` (the instrument frame at the middle)."""
    got = forward_kinematics(desc, joints, theta).positions
    want = forward_kinematics(desc, joints, robot.truth).positions
    return float(np.sqrt(np.mean(np.sum((got - want) ** 2, axis=1))))
