"""Independent yardsticks for identification tests: the truth robot's own Jacobians and errors."""

from __future__ import annotations

import numpy as np

from models import NoiseModel, RobotDescription, forward_kinematics
from models.simulation import SimulatedRobot

Array = np.ndarray


def cramer_rao_rms(
    desc: RobotDescription,
    sim: SimulatedRobot,
    fit_joints: Array,
    check_joints: Array,
    free: Array,
    noise: NoiseModel,
    *,
    position_only: bool,
) -> float:
    """RMS TCP position error an efficient estimator reaches at `check_joints`, from the Jacobian at the truth.

    Exactly redundant parameters do not move the TCP anywhere, so any identifiable subset gives the same value.
    """
    rows = 3 if position_only else 6
    jac = forward_kinematics(desc, fit_joints, sim.truth, jacobian=True).jacobians
    assert jac is not None
    w = np.array([1 / noise.position_mm] * 3 + [1 / noise.orientation_rad] * 3)[:rows]
    a = (jac[:, :rows, :][:, :, free] * w[None, :, None]).reshape(-1, free.size)
    cov = np.linalg.inv(a.T @ a)
    jv = forward_kinematics(desc, check_joints, sim.truth, jacobian=True).jacobians
    assert jv is not None
    jp = jv[:, :3, free]
    return float(np.sqrt(np.mean(np.einsum("mij,jk,mik->m", jp, cov, jp))))


def rms_position_error(desc: RobotDescription, params: Array, sim: SimulatedRobot, joints: Array) -> float:
    truth = forward_kinematics(desc, joints, sim.truth).positions
    model = forward_kinematics(desc, joints, params).positions
    return float(np.sqrt(np.mean(np.sum((model - truth) ** 2, axis=1))))


def nominal_in_true_frame(desc: RobotDescription, sim: SimulatedRobot) -> Array:
    """The drawing's geometry placed in the instrument frame exactly: the robot's own error before calibration."""
    theta = sim.nominal.copy()
    theta[desc.slices["base"]] = sim.truth[desc.slices["base"]]
    return theta
