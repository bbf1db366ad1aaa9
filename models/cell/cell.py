"""A cell: the robot's collision geometry, the fixed obstacles, the instruments, the clearance, and which pairs of
solids may touch.

Allowed pairs are visible and editable (`Cell.allowed`): real arms' neighbouring shapes touch, and a base sits on
its table. `default_allowed` lists the pairs a cell starts with, each with why: bodies adjacent along the chain
(`adjacent`), and pairs already within the clearance at the reference pose (`touching at reference`: the
robot's mount on its table, a wrist whose capsules overlap by construction). The reference pose defaults to the
middle of each joint's range: a user whose arm lies on the table there gives another.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from models._types import IDENTITY, Pose6
from models.cell.geometry import RobotGeometry
from models.cell.instruments import Ballbar, Camera, Tracker
from models.cell.shapes import Shape
from models.errors import InvalidInput

Pair = frozenset[str]


def pair(a: str, b: str) -> Pair:
    return frozenset((a, b))


@dataclass(frozen=True)
class Obstacle:
    """A fixed solid: `shape` at `pose` in the world frame (position mm, rotation vector rad)."""

    name: str
    shape: Shape
    pose: Pose6 = IDENTITY

    def __post_init__(self) -> None:
        if not self.name:
            raise InvalidInput("an obstacle needs a name (refusals name the solid they hit)", field="obstacles.name")
        if len(self.pose) != 6 or not np.isfinite(np.asarray(self.pose, dtype=float)).all():
            raise InvalidInput(
                f"obstacle {self.name!r}: pose is x, y, z (mm) and a rotation vector (rad), 6 finite numbers",
                field="obstacles.pose",
            )


@dataclass(frozen=True)
class Cell:
    geometry: RobotGeometry
    obstacles: tuple[Obstacle, ...] = ()
    tracker: Tracker | None = None
    camera: Camera | None = None
    ballbar: Ballbar | None = None
    clearance: float = 10.0
    """The least distance (mm) between two solids that may not touch."""
    allowed: frozenset[Pair] = field(default_factory=frozenset)
    """Pairs of body or obstacle names that may touch (see the module docstring)."""

    def __post_init__(self) -> None:
        names = [o.name for o in self.obstacles]
        clash = set(names) & set(self.geometry.bodies)
        if len(set(names)) != len(names) or clash:
            raise InvalidInput(
                f"obstacle names must be unique and differ from the robot's bodies ({', '.join(sorted(clash))})",
                field="obstacles",
            )
        if not self.clearance >= 0:
            raise InvalidInput(f"clearance must be non-negative (mm), got {self.clearance}", field="clearance")
        known = set(names) | set(self.geometry.bodies)
        for p in self.allowed:
            unknown = sorted(p - known)
            if unknown:
                raise InvalidInput(f"allowed pair names unknown solids: {', '.join(unknown)}", field="allowed")

    def allowing(self, *pairs: tuple[str, str]) -> Cell:
        """This cell with more allowed pairs."""
        return replace(self, allowed=self.allowed | {pair(a, b) for a, b in pairs})
