"""Example trees: the cells issue 47 names, as test and benchmark subjects (rounded public geometries).

- `dual_arm_torso`: a waist joint shared by two UR5-like 6R arms (standard DH, Universal Robots' published
  table), each on a shoulder flange of the torso tilted outwards, each with its own tool;
- `arm_with_positioner`: the UR5-like arm and a two-axis (tilt, turn) welding positioner 1.2 m in front of it
  on one floor; the arm's tool is the torch, the positioner's the part frame on its table.
"""

from __future__ import annotations

import math

from models.description.examples import UR5_DH
from models.description.structure import description_from_document
from models.stages import SerialStage
from models.tree.tree import Branch, RobotTree

TORCH = (60.0, -40.0, 120.0, 0.0, 0.0, 0.0)
"""A tool off the last joint's axis (mm, rotation vector): on the axis, position records would not see the
last joint's offset."""
PART = (150.0, 80.0, 40.0, 0.0, 0.0, 0.3)
"""The part frame on the positioner's table, off its turning axis."""


def _serial(links: list[dict[str, object]], convention: str = "dh") -> SerialStage:
    """The serial stage of robots.md links (mm and degrees), read by the document reader."""
    desc = description_from_document({"stages": [{"kind": "serial", "convention": convention, "links": links}]})
    stage = desc.stages[0]
    assert isinstance(stage, SerialStage)
    return stage


def _arm() -> SerialStage:
    return _serial([dict(row) for row in UR5_DH])


WAIST = {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 400.0, "theta": 0.0, "range": [-170.0, 170.0]}
"""The torso's waist: a vertical axis 400 mm up; the shoulders sit on the torso above it."""


def dual_arm_torso() -> RobotTree:
    tilt = math.radians(30.0)
    left = (0.0, 250.0, 350.0, -tilt, 0.0, 0.0)  # shoulder flanges 250 mm either side, tilted outwards by 30°
    right = (0.0, -250.0, 350.0, tilt, 0.0, 0.0)
    return RobotTree(
        "dual-arm-torso",
        (
            Branch("waist", (_serial([WAIST]),)),
            Branch("left", (_arm(),), parent="waist", mount=left, tool=TORCH),
            Branch("right", (_arm(),), parent="waist", mount=right, tool=TORCH),
        ),
    )


POSITIONER = [
    {"joint": "revolute", "a": 0.0, "alpha": -90.0, "d": 0.0, "theta": 0.0, "range": [-90.0, 90.0]},
    {"joint": "revolute", "a": 0.0, "alpha": 0.0, "d": 200.0, "theta": 0.0, "range": [-180.0, 180.0]},
]
"""Tilt about the mount's z axis (horizontal), then the table turning about its normal, 200 mm above the tilt
axis (vertical at zero tilt)."""


def arm_with_positioner() -> RobotTree:
    # The tilt axis is horizontal, 600 mm up: the mount turns the floor's z onto −y (90° about x).
    mount = (1200.0, 0.0, 600.0, math.pi / 2, 0.0, 0.0)
    return RobotTree(
        "arm-and-positioner",
        (
            Branch("arm", (_arm(),), tool=TORCH),
            Branch("positioner", (_serial(POSITIONER),), mount=mount, tool=PART),
        ),
    )
