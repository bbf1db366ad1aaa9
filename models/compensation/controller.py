"""The controller's base frame: where a robot program's targets are expressed.

A controller's targets are in its own base frame (KUKA's $ROBROOT, ABB's base frame, UR's Base), which is the
frame the robot was *described* from, not the model's frame {0}. For a DH or MDH document the two are one: the
table starts at the controller's base. A robot imported from a URDF (or from UR's kinematics file, through the
URDF it makes) is re-described in MDH from its joint axes (`models.formats.urdf`), and frame {0} then sits on the first
joint axis, turned to suit the table: a UR10e's {0} is 180.7 mm above its Base, a KUKA URDF's (A1 about −z)
400 mm above and half a turn away from $ROBROOT. The import keeps base_link <- {0} as the model's nominal base;
a calibration replaces the base with the instrument's frame, so the controller's frame has to be kept apart:
{0} <- controller frame is the *nominal* geometry's, fixed by the description the controller runs.

The controller frame of a URDF robot is its chain's root (`base_link`), or, where the URDF follows ROS-Industrial's
convention of a fixed child link named `base` ("base_link to the vendor's controller base frame": identity for
KUKA and ABB, a half turn about z for a UR's `base_link`), that `base`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from models._types import Array
from models.formats.urdf import MM_PER_M, document_from_urdf, load_urdf
from models.transforms import quaternion_to_matrix

ROS_INDUSTRIAL_BASE = "base"
"""ROS-Industrial's name for the link that is the controller's base frame, a fixed child of base_link (REP-I0005
style robot descriptions: `kuka_experimental`, `abb_experimental`, `ur_description`)."""


@dataclass(frozen=True)
class ControllerFrame:
    """The frame a controller's targets are in, as the model's {0} <- that frame (nominal geometry, mm)."""

    name: str
    zero_from_controller: Array = field(default_factory=lambda: np.eye(4))
    """{0} <- controller base frame: a target T in the controller's frame is zero_from_controller @ T in {0}."""

    @property
    def is_zero(self) -> bool:
        return bool(np.allclose(self.zero_from_controller, np.eye(4), atol=1e-12))


ZERO = ControllerFrame("the model's base frame {0} (the first frame of the DH/MDH table)")
"""A robot described by a DH/MDH document (or the IWR): the table starts at the controller's base."""


def _pose(doc: dict[str, Any]) -> Array:
    """A robots.md pose (position mm, quaternion [w, x, y, z]) as a 4x4."""
    out = np.eye(4)
    out[:3, :3] = np.asarray(quaternion_to_matrix(np.asarray(doc["orientation"], dtype=float)), dtype=float)
    out[:3, 3] = np.asarray(doc["position"], dtype=float)
    return out


def _ros_industrial_base(urdf: str, base_link: str) -> Array | None:
    """base_link <- `base` (mm) where the URDF has a fixed joint from base_link to a link named `base`."""
    for joint in load_urdf(urdf).joints:
        if joint.parent == base_link and joint.child == ROS_INDUSTRIAL_BASE and joint.type == "fixed":
            t = np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=float)
            t[:3, 3] *= MM_PER_M
            return t
    return None


@lru_cache(maxsize=64)
def urdf_controller_frame(urdf: str, base_link: str, tip_link: str, *, ur_file: bool = False) -> ControllerFrame:
    """The controller frame of a robot imported from this URDF chain (the import is re-run: its base is
    base_link <- {0}). `ur_file`: the URDF was made from UR's kinematics file, whose root is UR's Base."""
    imported = _pose(document_from_urdf(urdf, base_link, tip_link)["base"])
    zero_from_root = np.asarray(np.linalg.inv(imported), dtype=float)
    if ur_file:
        return ControllerFrame(f"UR's Base ({base_link}, the kinematics file's origin)", zero_from_root)
    ros_base = None if base_link == ROS_INDUSTRIAL_BASE else _ros_industrial_base(urdf, base_link)
    if ros_base is not None:
        return ControllerFrame(
            f"the URDF's {ROS_INDUSTRIAL_BASE!r} link (ROS-Industrial's controller base frame, fixed to {base_link!r})",
            np.asarray(zero_from_root @ ros_base, dtype=float),
        )
    return ControllerFrame(f"the URDF's {base_link!r} link (the chain's root)", zero_from_root)


__all__ = ["ZERO", "ControllerFrame", "urdf_controller_frame"]
