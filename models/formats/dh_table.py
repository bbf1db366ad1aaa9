"""The calibrated DH (or MDH) table of a serial arm, with its base and tool, as a controller's table takes it.

A controller that models its arm by DH numbers (a KUKA machine data file, a Stäubli or Fanuc DH table, one's
own kinematics) can take the calibrated values only when the calibrated model *is* a DH chain: a serial arm
whose whole calibrated geometry is its links' numbers, the base and the tool. So the table refuses what it
could only approximate — a parallel stage (a hexapod, a hybrid robot) and the model terms (thermal expansion,
joint compliance), whose effect no DH number carries.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import Convention
from models.errors import InvalidInput
from models.formats.joint_chain import pose_matrix, rpy_of, serial_only


@dataclass(frozen=True)
class FrameRow:
    """A transform as x, y, z (mm) and URDF's fixed-axis roll, pitch, yaw (deg): R = Rz(yaw)·Ry(pitch)·Rx(roll)."""

    x_mm: float
    y_mm: float
    z_mm: float
    roll_deg: float
    pitch_deg: float
    yaw_deg: float


@dataclass(frozen=True)
class LinkRow:
    joint: int
    name: str | None
    """The joint's reading (`q1` …), or None for a fixed link."""
    type: str
    convention: str
    theta_deg: float
    d_mm: float
    a_mm: float
    alpha_deg: float
    beta_deg: float | None
    """Hayati's tilt about y, where the link has it; None where it has not (not 0: the link has no such term)."""
    range: tuple[float, float] | None
    """The joint's range (deg, mm for prismatic); None for a fixed link."""


@dataclass(frozen=True)
class DhTable:
    base: FrameRow
    links: tuple[LinkRow, ...]
    tool: FrameRow


def geometric_only(desc: RobotDescription, what: str) -> None:
    """Refuse a model with thermal or compliance terms: `what` has no place for their effect."""
    if desc.terms.any:
        terms = [t for t, on in (("thermal", desc.terms.thermal), ("compliance", desc.terms.compliance)) if on]
        raise InvalidInput(
            f"this version was calibrated with the {' and '.join(terms)} term: {what} holds the geometry alone, "
            "and without the term's effect its FK is not the calibrated robot's; export a version calibrated "
            "without terms (?version=n), or the parameters themselves (?format=json)",
            field="format",
            reason="model_terms",
            value=", ".join(terms),
        )


def frame_row(p6: Array) -> FrameRow:
    t = pose_matrix(p6)
    roll, pitch, yaw = (math.degrees(v) for v in rpy_of(t[:3, :3]))
    x, y, z = (float(v) + 0.0 for v in t[:3, 3])  # + 0.0: no "-0.0" in a table a person reads
    return FrameRow(x, y, z, roll + 0.0, pitch + 0.0, yaw + 0.0)


def dh_table(desc: RobotDescription, params: Array) -> DhTable:
    """The table of `desc` with the values `params` (internal units); InvalidInput (field `format`) for a
    parallel stage or model terms."""
    serial_only(desc, "a DH table")
    geometric_only(desc, "a DH table")
    theta = desc.parameters.vector(params)
    index = desc.parameters.index
    rows = []
    number = 0
    for k, link in enumerate(desc.links, start=1):
        value = {f: float(theta[index[f"link{k}.{f}"]]) for f in link.fields}
        number += link.joint.moves
        scale = 1.0 if link.joint.kind.boundary_unit == "mm" else math.degrees(1.0)
        rows.append(
            LinkRow(
                joint=k,
                name=f"q{number}" if link.joint.moves else None,
                type=link.joint.value,
                convention=link.convention.value,
                theta_deg=math.degrees(value["theta"]),
                d_mm=value["d"],
                a_mm=value["a"],
                alpha_deg=math.degrees(value["alpha"]),
                beta_deg=math.degrees(value["beta"]) if "beta" in value else None,
                range=(link.joint_min * scale, link.joint_max * scale) if link.joint.moves else None,
            )
        )
    return DhTable(frame_row(theta[desc.slices["base"]]), tuple(rows), frame_row(theta[desc.slices["tool"]]))


LINK_TRANSFORMS = {
    Convention.DH.value: "A = Rz(theta + q)·Tz(d + q)·Tx(a)·Rx(alpha)·Ry(beta)",
    Convention.MDH.value: "A = Rx(alpha)·Ry(beta)·Tx(a)·Rz(theta + q)·Tz(d + q)",
}
"""Each link's transform (q adds to theta for a revolute joint, to d for a prismatic one; beta 0 where absent)."""
