"""The IWR (Intersector Welding Robot) of `shared/spec/iwr-model.md`."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from models._types import IDENTITY, Pose6
from models.description.hexapod import HexapodGeometry
from models.description.robot import RobotDescription
from models.description.serial_chain import DHLink, JointType
from models.stages import HexapodStage, SerialStage

_DEG = float(np.pi / 180.0)

BASE_RADIUS_MM = 328.0
PLATFORM_RADIUS_MM = 130.0
BASE_ANGLES_DEG = (-15.0, 15.0, 105.0, 135.0, 225.0, 255.0)
PLATFORM_ANGLES_DEG = (-45.0, 45.0, 75.0, 165.0, 195.0, 285.0)


def _circle(radius: float, angles_deg: tuple[float, ...]) -> tuple[tuple[float, float, float], ...]:
    return tuple((radius * float(np.cos(a * _DEG)), radius * float(np.sin(a * _DEG)), 0.0) for a in angles_deg)


IWR_LINKS: tuple[DHLink, ...] = (
    DHLink(JointType.PRISMATIC, theta=0.0, d=0.0, a=91.0, alpha=90 * _DEG, joint_min=0.0, joint_max=800.0),
    DHLink(JointType.PRISMATIC, theta=90 * _DEG, d=0.0, a=0.0, alpha=90 * _DEG, joint_min=0.0, joint_max=300.0),
    DHLink(JointType.REVOLUTE, theta=0.0, d=331.0, a=252.0, alpha=90 * _DEG, joint_min=0.0, joint_max=180 * _DEG),
    DHLink(JointType.REVOLUTE, theta=0.0, d=0.0, a=354.0, alpha=-90 * _DEG, joint_min=0.0, joint_max=90 * _DEG),
)

IWR_HEXAPOD = HexapodGeometry(
    base_joints=_circle(BASE_RADIUS_MM, BASE_ANGLES_DEG),
    platform_joints=_circle(PLATFORM_RADIUS_MM, PLATFORM_ANGLES_DEG),
    leg_offsets=(0.0,) * 6,
    stroke_min=370.0,
    stroke_max=550.0,
    home=(0.0, 0.0, 400.0, 0.0, 0.0, 0.0),
    workspace_min=(-40.0, -40.0, 360.0, 0.0, 0.0, 0.0),
    workspace_max=(40.0, 40.0, 440.0, 15 * _DEG, 15 * _DEG, 10 * _DEG),
    max_condition=100.0,
)


# A memo of immutable values, not of built artefacts (those live in `models.engine.runtime`): a description
# with its derived tables costs ~75 µs to rebuild, most of a single-pose FK request. Bounded, since a
# service sees one (base, tool) pair per robot.
@lru_cache(maxsize=256)
def iwr(base: Pose6 = IDENTITY, tool: Pose6 = IDENTITY) -> RobotDescription:
    """The IWR description; `base` and `tool` are the user's nominal guesses (mm, rotation vector rad)."""
    return RobotDescription(
        name="iwr", stages=(SerialStage(IWR_LINKS), HexapodStage(IWR_HEXAPOD)), base=base, tool=tool
    )
