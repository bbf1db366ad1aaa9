"""The check before anything goes to a controller: does the nominal model reproduce what the controller's
pendant displays? A controller shows the TCP pose it computes from its joints with its own (nominal) model; a
compensated program is only right if our nominal model is that model — the same convention, the same tool,
the same units. A few readings (joints and the displayed pose) settle it, and a mismatch is named:

- the joints were given in radians (the model reproduces the readings with them read as radians);
- the tool differs (the errors are one constant vector in the tool frame: the controller's active tool is
  not the model's), with that vector;
- the positions are in metres or inches (the model's positions are the readings' times a unit);
- otherwise the model does not match (another convention, another robot), with the worst reading.

Poses are in the controller's robot-base frame: the model's own base transform is left out (the controller
knows nothing of where a tracker stood).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.description.parameters import Kind
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.kinematics import ForwardResult, forward_kinematics

POSITION_TOLERANCE_MM = 0.5
"""A controller's own model and ours agree to micrometres when they are the same model; a factory calibration
in the controller moves the TCP by tenths of a millimetre; a wrong tool or convention by tens of millimetres."""
ORIENTATION_TOLERANCE_RAD = math.radians(0.2)
TOOL_SPREAD_MM = 0.5
"""Errors that are one vector in the tool frame to within this are a tool offset, not a model mismatch."""
UNITS = {"metres": 1000.0, "inches": 25.4}


@dataclass(frozen=True)
class PendantCheck:
    position_errors_mm: Array
    """Per reading: displayed minus model position, its norm."""
    orientation_errors_rad: Array | None
    """Per reading (None where no reading gave an orientation)."""
    finding: str | None
    """What differs, in words an engineer can act on; None: the model reproduces the pendant."""

    @property
    def agrees(self) -> bool:
        return self.finding is None


def check_pendant(
    desc: RobotDescription,
    nominal: Array,
    joints: Array,
    positions_mm: Array,
    rotations: Array | None = None,
    *,
    tolerance_mm: float = POSITION_TOLERANCE_MM,
    tolerance_rad: float = ORIENTATION_TOLERANCE_RAD,
    runtime: Runtime | None = None,
) -> PendantCheck:
    """`joints` (n, n_joints, internal units) and what the pendant displayed at them: positions (n, 3, mm) and
    optionally rotations (n, 3, 3), in the robot-base frame. Checked against the model `nominal`."""
    rt = runtime_for(desc, runtime)
    model = _in_base(desc, nominal, joints, rt)
    position = np.linalg.norm(positions_mm - model.positions, axis=1)
    orientation = None
    if rotations is not None:
        turn = np.einsum("nji,njk->nik", model.rotations, rotations)
        orientation = np.arccos(np.clip((np.trace(turn, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0))
    bad = position > tolerance_mm
    if orientation is not None:
        bad |= orientation > tolerance_rad
    finding = None
    if bad.any():
        finding = _named(desc, nominal, joints, positions_mm, model=model, position=position, rt=rt) or (
            f"the nominal model does not reproduce the pendant: reading {int(np.argmax(position))} is "
            f"{position.max():.4g} mm off"
            + ("" if orientation is None else f" and {math.degrees(float(orientation.max())):.3g}° turned")
            + f" (tolerance {tolerance_mm:g} mm): another convention or another robot's model; fix the robot's "
            "description before sending anything to this controller"
        )
    return PendantCheck(position, orientation, finding)


def _in_base(desc: RobotDescription, theta: Array, joints: Array, rt: Runtime) -> ForwardResult:
    """Forward kinematics in the robot-base frame: the model's base transform left out."""
    at_base = np.asarray(theta, dtype=float).copy()
    at_base[desc.slices["base"]] = 0.0
    return forward_kinematics(desc, joints, at_base, check_ranges=False, runtime=rt)


def _named(
    desc: RobotDescription,
    nominal: Array,
    joints: Array,
    positions_mm: Array,
    *,
    model: ForwardResult,
    position: Array,
    rt: Runtime,
) -> str | None:
    """The slip the readings betray, if one explains them (see the module docstring)."""
    revolute = np.array([k is Kind.ANGLE for k in desc.joint_kinds])
    if revolute.any() and np.all(np.abs(joints[:, revolute]) < math.pi / 180 * math.pi + 1e-12):
        # Degrees that are radians: every revolute joint within ±π°, read back as radians.
        as_radians = joints.copy()
        as_radians[:, revolute] *= 180.0 / math.pi
        again = _in_base(desc, nominal, as_radians, rt)
        if np.linalg.norm(positions_mm - again.positions, axis=1).max() < 0.1 * position.max():
            return "the joints look like radians: give revolute joints in degrees"
    fk = model
    in_tool = np.einsum("nji,nj->ni", fk.rotations, positions_mm - fk.positions)
    offset = in_tool.mean(axis=0)
    if np.linalg.norm(in_tool - offset, axis=1).max() < TOOL_SPREAD_MM and joints.shape[0] >= 2:
        return (
            f"the controller's tool is not the model's: the readings are [{offset[0]:.3f}, {offset[1]:.3f}, "
            f"{offset[2]:.3f}] mm from the model's TCP in the tool frame, at every reading; set the robot's tool "
            "(or the controller's active tool) so that they agree"
        )
    for unit, factor in UNITS.items():
        scaled = np.linalg.norm(positions_mm * factor - fk.positions, axis=1)
        if scaled.max() < 0.1 * position.max():
            return f"the displayed positions look like {unit}: give them in mm"
    return None
