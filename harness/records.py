"""Simulated measurements in the API's boundary units (the records a calibration request carries)."""

from __future__ import annotations

import numpy as np

from models import RobotDescription
from models.simulation import SimulatedRobot, measure


def records(
    desc: RobotDescription, sim: SimulatedRobot, joints: np.ndarray, seed: int, *, position_only: bool = False
) -> list[dict[str, object]]:
    campaign = measure(sim, joints, seed=seed, position_only=position_only)
    out = []
    for k in range(campaign.size):
        rec: dict[str, object] = {
            "joints": (campaign.joints[k] * desc.joint_to_boundary).tolist(),
            "position": campaign.positions[k].tolist(),
        }
        if campaign.quaternions is not None:
            rec["orientation"] = campaign.quaternions[k].tolist()
        out.append(rec)
    return out
