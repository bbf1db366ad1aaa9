"""The instruments of a cell, in the world frame of the robot's description (the frame its `base` pose is
given in), mm and radians: what each must see of the tool for a pose to be measurable.

Defaults a user sees here: a laser tracker's range 1 000-20 000 mm and a reflector's acceptance half-angle of
30° (a spherically mounted retro-reflector's usual figure), the reflector at the TCP facing along the TCP's z;
a beam kept 5 mm clear of every other solid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import IDENTITY, Pose6, Vec3
from models.errors import InvalidInput

_Z: Vec3 = (0.0, 0.0, 1.0)
_ORIGIN: Vec3 = (0.0, 0.0, 0.0)


def _finite(values: tuple[float, ...], field: str) -> None:
    if not np.isfinite(np.asarray(values, dtype=float)).all():
        raise InvalidInput(f"{field} must be finite numbers", field=field)


def _range(lo: float, hi: float, field: str) -> None:
    if not (np.isfinite(lo) and np.isfinite(hi) and 0 <= lo < hi):
        raise InvalidInput(f"{field}: need 0 <= min < max (mm), got {lo}, {hi}", field=field)


def _acceptance(value: float, field: str) -> None:
    if not 0 < value <= np.pi:
        raise InvalidInput(f"{field}: a half-angle in (0, 180°]", field=field)


def _clearance(value: float, field: str) -> None:
    if not (np.isfinite(value) and value > 0):
        raise InvalidInput(f"{field} must be positive (mm)", field=field)


@dataclass(frozen=True)
class Target:
    """Where the measured point sits on the tool (TCP frame, mm) and which way it faces (a direction there)."""

    offset: Vec3 = _ORIGIN
    facing: Vec3 = _Z
    carried_by: tuple[str, ...] = ("tool",)
    """Bodies the sight line may touch at its end: those that carry the target."""

    def __post_init__(self) -> None:
        _finite(self.offset + self.facing, "target")
        if np.linalg.norm(self.facing) < 1e-9:
            raise InvalidInput("the target's facing direction must not be zero", field="target.facing")


@dataclass(frozen=True)
class Tracker:
    """A laser tracker at `position`; a pose is seen if the reflector is within range, faces the tracker
    within its acceptance cone, and the beam passes `beam_clearance` clear of every link and obstacle."""

    position: Vec3
    range_min: float = 1000.0
    range_max: float = 20000.0
    acceptance: float = float(np.radians(30.0))
    """The reflector's acceptance cone half-angle (rad)."""
    reflector: Target = Target()
    beam_clearance: float = 5.0

    def __post_init__(self) -> None:
        _finite(self.position, "tracker.position")
        _range(self.range_min, self.range_max, "tracker.range")
        _acceptance(self.acceptance, "tracker.acceptance")
        _clearance(self.beam_clearance, "tracker.beam_clearance")


@dataclass(frozen=True)
class Camera:
    """A camera at `pose` (world <- camera: position, rotation vector; it looks along its z, x to the image's
    right); a pose is seen if the target is inside the field of view and its depth range, faces the camera
    within `acceptance`, and the sight line is clear like a tracker's beam."""

    pose: Pose6 = IDENTITY
    half_width: float = float(np.radians(30.0))
    half_height: float = float(np.radians(22.5))
    range_min: float = 300.0
    range_max: float = 5000.0
    acceptance: float = float(np.radians(60.0))
    target: Target = Target()
    sight_clearance: float = 5.0

    def __post_init__(self) -> None:
        _finite(self.pose, "camera.pose")
        _range(self.range_min, self.range_max, "camera.range")
        for name in ("half_width", "half_height"):
            if not 0 < getattr(self, name) < np.pi / 2:
                raise InvalidInput(f"camera.{name}: a half-angle in (0, 90°)", field=f"camera.{name}")
        # As the tracker's: a NaN or zero cone would see nothing, and a negative clearance let a sight line
        # graze a link (neither was checked here before).
        _acceptance(self.acceptance, "camera.acceptance")
        _clearance(self.sight_clearance, "camera.sight_clearance")


@dataclass(frozen=True)
class Ballbar:
    """A ballbar from a fixed pivot to the TCP (plus `tcp_offset`): its length must stay within its travel."""

    pivot: Vec3
    length_min: float
    length_max: float
    tcp_offset: Vec3 = _ORIGIN

    def __post_init__(self) -> None:
        _finite(self.pivot + self.tcp_offset, "ballbar")
        _range(self.length_min, self.length_max, "ballbar.length")
