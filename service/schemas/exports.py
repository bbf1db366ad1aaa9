"""The controller exports of `GET /v1/robots/{id}/parameters?format=`: the DH table's JSON layout (`dh`); UR's
kinematics file and the URDF are text in their vendors' formats (docs/exports.md)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from service.schemas.common import Public

ROTATION = (
    "roll, pitch, yaw about the fixed x, y, z axes: R = Rz(yaw)·Ry(pitch)·Rx(roll) (URDF's rpy; the same matrix as "
    "the intrinsic Z-Y'-X'' angles yaw, pitch, roll, KUKA's A, B, C)"
)


class FramePublic(Public):
    """A transform: translation (mm), then the rotation as roll, pitch, yaw (deg), R = Rz(yaw)·Ry(pitch)·Rx(roll)."""

    x_mm: float
    y_mm: float
    z_mm: float
    roll_deg: float
    pitch_deg: float
    yaw_deg: float


class DhLinkPublic(Public):
    joint: int = Field(description="The link's number, 1 … n, base to tool")
    name: str | None = Field(description="Its joint reading (q1 …), null for a fixed link")
    type: Literal["revolute", "prismatic", "fixed"]
    convention: Literal["dh", "mdh"] = Field(description="The link's transform: see `link_transforms`")
    theta_deg: float
    d_mm: float
    a_mm: float
    alpha_deg: float
    beta_deg: float | None = Field(description="Hayati's tilt about y where the link has one; null: no such term")
    range: list[float] | None = Field(description="The joint's range, deg (mm for prismatic); null when fixed")


class DhTablePublic(Public):
    """The calibrated DH (or MDH) table: world <- TCP = base · A_1(q) ⋯ A_n(q) · tool."""

    format: Literal["dh"] = "dh"
    robot_id: str
    version: int
    frame: str = Field(description="What `base` maps: the measurements' frame from the robot's base frame {0}")
    pose: str = Field(description="How the table composes: world <- TCP = base · A_1 ⋯ A_n · tool")
    link_transforms: dict[str, str] = Field(description="A_i of each convention, q the joint's reading")
    rotation: str = Field(description="The convention of every roll, pitch, yaw here", examples=[ROTATION])
    base: FramePublic = Field(description="world (the measurements' frame: the tracker's) <- robot base {0}")
    links: list[DhLinkPublic]
    tool: FramePublic = Field(description="The last link's frame {n} -> TCP")
