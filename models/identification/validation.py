"""A calibrated model judged on measurements it was not fitted to."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime
from models.identification.registration import registered_base, rigid_fit
from models.identification.result import ResidualSummary
from models.identification.statistics import PoseErrors
from models.kinematics import forward_kinematics
from models.transforms import matrix_to_rotvec_np


@dataclass(frozen=True)
class ValidationReport:
    errors: ResidualSummary
    registered: bool
    """Whether the instrument frame was re-fitted first (the instrument moved between campaigns)."""


def validate(
    desc: RobotDescription,
    params: Array,
    campaign: Campaign,
    *,
    register: bool = False,
    runtime: Runtime | None = None,
) -> ValidationReport:
    """Errors of the model `params` on `campaign`: the instrument in the same place, unless `register`."""
    theta = desc.parameters.vector(params)
    fk = forward_kinematics(desc, campaign.joints, theta, runtime=runtime)
    if register:
        theta = registered_base(desc, theta, rigid_fit(fk.positions, campaign.positions))
        fk = forward_kinematics(desc, campaign.joints, theta, seeds=fk.platforms, runtime=runtime)
    position = np.linalg.norm(fk.positions - campaign.positions, axis=1)
    orientation = None
    if not campaign.position_only:
        orientation = np.linalg.norm(matrix_to_rotvec_np(fk.rotations @ np.swapaxes(campaign.rotations, 1, 2)), axis=1)
    return ValidationReport(ResidualSummary.of(PoseErrors(position, orientation)), register)
