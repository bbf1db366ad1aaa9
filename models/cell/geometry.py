"""A robot's collision geometry: shapes attached to its bodies, from its links' lengths or from a URDF.

Two kinds of link shape. A `Segment` is a capsule between two points each fixed in a frame of
`models.cell.frames` (its length may follow the joints: a hexapod leg runs from its base joint to its platform
joint). An `Attached` shape (box, cylinder, sphere,
capsule, mesh) is rigid in one frame at a fixed pose: a URDF's `<collision>` elements.

Defaults for a DH or MDH document (`default_geometry`), a user sees them in `RobotGeometry.shapes`:

- each link i: two capsules, previous frame's origin -> the link's middle frame's origin -> its end frame's
  origin (the offset along the joint axis, then the common normal), of radius
  clamp(LINK_RADIUS_FRACTION · (|a_i| + |d_i|), LINK_RADIUS_MIN, LINK_RADIUS_MAX) mm. A prismatic link's stroke
  (its d, which its joint drives) is its guide, not metal that moves with it: it gets no capsule and does not
  count in the radius (model the guide as an obstacle); its fixed part (a) does;
- a parallel stage: one capsule per hexapod leg, base joint to platform joint, of radius LEG_RADIUS;
- the tool: one capsule from the last frame's origin to the TCP, of radius TOOL_RADIUS.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array, Vec3
from models.cell.frames import FrameLayout, frame_layout
from models.cell.shapes import Shape
from models.description.robot import RobotDescription
from models.description.serial_chain import Convention, JointType
from models.errors import InvalidInput
from models.stages import HexapodStage, SerialStage

LINK_RADIUS_FRACTION = 0.1
LINK_RADIUS_MIN = 25.0
LINK_RADIUS_MAX = 80.0
LEG_RADIUS = 20.0
TOOL_RADIUS = 20.0
ORIGIN: Vec3 = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class Segment:
    """A capsule of `radius` (mm) between point `a` of frame `frame_a` and point `b` of frame `frame_b`."""

    body: str
    frame_a: str
    frame_b: str
    radius: float
    a: Vec3 = ORIGIN
    b: Vec3 = ORIGIN


@dataclass(frozen=True)
class Attached:
    """`shape` rigid in frame `frame`, its own frame at `pose` there (4x4 by rows, mm)."""

    body: str
    frame: str
    shape: Shape
    pose: tuple[tuple[float, ...], ...]

    @property
    def matrix(self) -> Array:
        return np.asarray(self.pose, dtype=float)


LinkShape = Segment | Attached


@dataclass(frozen=True)
class RobotGeometry:
    """The shapes of a robot's bodies (frames named by `models.cell.frames.frame_layout`)."""

    shapes: tuple[LinkShape, ...]
    source: str
    """`links` (the defaults from the link lengths) or `urdf`."""
    skipped: tuple[str, ...] = ()
    """What a URDF had that is not modelled (a mesh the library cannot read here), by link."""

    def check(self, layout: FrameLayout) -> None:
        for s in self.shapes:
            for frame in (s.frame_a, s.frame_b) if isinstance(s, Segment) else (s.frame,):
                if frame not in layout.names:
                    raise InvalidInput(
                        f"link shape of {s.body!r}: no frame {frame!r} (frames: {', '.join(layout.names)})",
                        field="geometry",
                    )

    @property
    def bodies(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(s.body for s in self.shapes))


def link_radius(a: float, d: float) -> float:
    return float(np.clip(LINK_RADIUS_FRACTION * (abs(a) + abs(d)), LINK_RADIUS_MIN, LINK_RADIUS_MAX))


def default_geometry(desc: RobotDescription) -> RobotGeometry:
    """Capsules from the links' lengths (see the module docstring for the rule)."""
    shapes: list[LinkShape] = []
    previous, number = "base", 1
    for k, stage in enumerate(desc.stages):
        if isinstance(stage, SerialStage):
            for link in stage.links:
                body = f"link{number}"
                prismatic = link.joint is JointType.PRISMATIC
                r = link_radius(link.a, 0.0 if prismatic else link.d)
                if not prismatic or link.convention is Convention.MDH:
                    shapes.append(Segment(body, previous, f"{body}.mid", r))
                if not prismatic or link.convention is Convention.DH:
                    shapes.append(Segment(body, f"{body}.mid", body, r))
                previous, number = body, number + 1
            continue
        body = f"stage{k + 1}"
        if isinstance(stage, HexapodStage):
            g = stage.geometry
            shapes += [
                Segment(body, previous, body, LEG_RADIUS, a=tuple(map(float, b)), b=tuple(map(float, p)))  # type: ignore[arg-type]
                for b, p in zip(g.base_joints, g.platform_joints, strict=True)
            ]
        else:
            shapes.append(Segment(body, previous, body, LEG_RADIUS))
        previous = body
    shapes.append(Segment("tool", previous, "tcp", TOOL_RADIUS))
    geometry = RobotGeometry(tuple(shapes), "links")
    geometry.check(frame_layout(desc))
    return geometry
