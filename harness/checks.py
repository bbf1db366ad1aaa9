"""Simulated truths for the quick check (models.evaluation.checks): a robot calibrated from a simulated campaign, its
version
(values and covariance, as the service stores them) and the same robot after a known change."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models import NoiseModel, RobotDescription, forward_kinematics, sample_workspace
from models._types import Array
from models.evaluation.checks import version_covariance
from models.identification import identify
from models.simulation import SimulatedRobot, measure, perturbed_robot

CAMPAIGN_POSES = 60
LEVER_POSES = 400


@dataclass(frozen=True)
class Calibrated:
    robot: SimulatedRobot
    """The truth (its base: the instrument frame of the calibration)."""
    params: Array
    """The calibrated version's values."""
    covariance: Array
    """Its parameter covariance in table order, rebuilt from std errors and correlation as the service does."""


def calibrated(
    desc: RobotDescription, seed: int, *, noise: NoiseModel | None = None, position_only: bool = True
) -> Calibrated:
    """A perturbed truth calibrated from `CAMPAIGN_POSES` random poses measured with `noise`."""
    robot = perturbed_robot(desc, seed)
    campaign = measure(
        robot, sample_workspace(desc, CAMPAIGN_POSES, seed=seed + 1), noise, seed=seed + 2, position_only=position_only
    )
    fit = identify(desc, campaign, noise=noise, strict=True)
    sd = np.sqrt(np.diag(fit.covariance))
    correlation = fit.covariance / np.outer(sd, sd)
    covariance = version_covariance(desc.parameters, fit.std_errors, list(fit.identifiable_names), correlation)
    return Calibrated(robot, fit.parameters, covariance)


def tcp_equivalent(desc: RobotDescription, params: Array, index: int, mm: float) -> float:
    """The change of parameter `index` that moves the TCP by `mm` RMS over workspace poses (for a joint offset:
    the angle equivalent to `mm` at the TCP)."""
    joints = sample_workspace(desc, LEVER_POSES, seed=LEVER_POSES)
    column = forward_kinematics(desc, joints, params, jacobian=True).jacobians[:, :3, index]
    return mm / float(np.sqrt(np.mean(np.sum(column**2, axis=1))))


def changed(robot: SimulatedRobot, index: int, delta: float) -> SimulatedRobot:
    """The same robot with parameter `index` moved by `delta` (a crash, a replaced motor or tool)."""
    truth = robot.truth.copy()
    truth[index] += delta
    return SimulatedRobot(robot.desc, robot.nominal, truth)
