"""What a model's errors are on a campaign, and what TCP accuracy an estimate predicts over the workspace."""

from __future__ import annotations

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.identification.result import PredictedAccuracy
from models.identification.statistics import PoseErrors, tcp_accuracy
from models.kinematics import CLOSURE_TOLERANCE_MM, pose_jacobian_batch, solve_platforms
from models.measurements import ModelBatch, measurement
from models.robot import RobotDescription
from models.runtime import Runtime
from models.workspace import workspace_samples

ACCURACY_SEED = 20_090_102
"""Seed of the workspace poses the predicted accuracy is averaged over (fixed: results are comparable)."""


def pose_errors(
    desc: RobotDescription, campaign: Campaign, theta: Array, seeds: Array | None, *, runtime: Runtime
) -> PoseErrors:
    """Position and orientation error of the model `theta` at each measured pose."""
    cond = campaign.condition_inputs(desc)
    platforms, _ = solve_platforms(desc, campaign.joints, theta, seeds, runtime=runtime, conditions=cond)
    model = ModelBatch(runtime.kinematics, campaign.joints, theta, platforms, cond)
    res = measurement(campaign.kind).residuals(model, campaign, np.arange(campaign.size, dtype=np.intp))
    return PoseErrors.from_raw(res)


def predicted_accuracy(
    desc: RobotDescription, theta: Array, free: Array, cov_theta: Array, samples: int, *, runtime: Runtime
) -> PredictedAccuracy:
    """TCP uncertainty over random workspace poses from the parameter covariance (first order)."""
    joints = workspace_samples(desc, samples, ACCURACY_SEED, runtime=runtime)
    platforms, closure = solve_platforms(desc, joints, theta, runtime=runtime)
    ok = closure <= CLOSURE_TOLERANCE_MM
    fk = pose_jacobian_batch(desc, joints[ok], theta, platforms[ok], runtime=runtime)
    pos, rot = tcp_accuracy(fk.jacobians[:, :, free], cov_theta)
    return PredictedAccuracy(
        rms_position_mm=float(np.sqrt(np.mean(pos**2))),
        max_position_mm=float(pos.max()),
        rms_orientation_rad=float(np.sqrt(np.mean(rot**2))),
        max_orientation_rad=float(rot.max()),
        poses=int(ok.sum()),
    )
