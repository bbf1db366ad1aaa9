"""A serial robot as a controller reads it: fixed joint origins, each followed by its joint's motion about z.

Every serial structure (DH or MDH links, fixed links) has this form. Link k's transform is `P_k · M(q_k) · S_k`
with M a rotation about (revolute) or a translation along (prismatic) z, the identity for a fixed link:

- DH: `Rz(θ+q)·Tz(d)·Tx(a)·Rx(α)·Ry(β)`; its `Rz(θ)·Tz(d)` commutes with M, so P = Rz(θ)·Tz(d) and
  S = Tx(a)·Rx(α)·Ry(β);
- MDH: `Rx(α)·Ry(β)·Tx(a)·Rz(θ+q)·Tz(d)`: P is all of it, S the identity.

So world <- TCP = base · Π_k (origin_k · M(q_k)) · flange · tool, with origin_k = S_{k-1} · P_k and flange = S_n.
URDF, UR's kinematics file and any controller that chains joint origins read a robot this way (`models.formats.urdf`,
`models.formats.ur_kinematics`, `models.formats.urdf_calibrated`). Putting a DH link's θ and d before its motion is
what UR's
`ur_calibration` does (its `shoulder` holds d1): the joint frame then sits where the link's z offset ends.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import Convention, JointType
from models.errors import InvalidInput
from models.stages import SerialStage
from models.transforms import rotvec_to_matrix_np


def rx(a: float) -> Array:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def ry(a: float) -> Array:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s, 0], [0, 1, 0, 0], [-s, 0, c, 0], [0, 0, 0, 1.0]])


def rz(a: float) -> Array:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def translation(x: float, y: float, z: float) -> Array:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def pose_matrix(p6: Array) -> Array:
    """The 4x4 transform of (x, y, z, rotation vector)."""
    t = np.eye(4)
    t[:3, :3] = rotvec_to_matrix_np(p6[3:6])
    t[:3, 3] = p6[:3]
    return t


def rpy_of(r: Array) -> tuple[float, float, float]:
    """URDF's fixed-axis roll, pitch, yaw: R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    pitch = math.atan2(-r[2, 0], math.hypot(r[0, 0], r[1, 0]))
    if math.cos(pitch) > 1e-12:
        return math.atan2(r[2, 1], r[2, 2]), pitch, math.atan2(r[1, 0], r[0, 0])
    return math.atan2(-r[1, 2], r[1, 1]), pitch, 0.0  # gimbal lock: roll takes it all


def rpy_matrix(roll: float, pitch: float, yaw: float) -> Array:
    return rz(yaw) @ ry(pitch) @ rx(roll)


@dataclass(frozen=True)
class JointChain:
    """world <- TCP = base · Π_k (origins[k] · M(q_k)) · flange · tool (mm, 4x4 each)."""

    base: Array
    origins: tuple[Array, ...]
    joints: tuple[JointType, ...]
    flange: Array
    tool: Array


def serial_only(desc: RobotDescription, what: str) -> None:
    """Refuse a structure with a parallel (or any non-serial) stage: `what` cannot describe it."""
    others = sorted({stage.kind for stage in desc.stages if not isinstance(stage, SerialStage)})
    if others:
        raise InvalidInput(
            f"{what} describes serial arms; this robot has a {' and a '.join(others)} stage, whose closed chain "
            "no table of joint origins can hold",
            field="format",
            reason="not_serial",
            value=", ".join(others),
        )


def joint_chain(desc: RobotDescription, params: Array | None = None, *, what: str = "a chain of joints") -> JointChain:
    """The joint-origin form of a serial robot with the values of `params` (internal units; default nominal);
    InvalidInput naming `what` (the format asked for) for a structure with a parallel stage."""
    serial_only(desc, what)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    index = desc.parameters.index
    origins: list[Array] = []
    carry = np.eye(4)  # S_{k-1}: what the previous link leaves after its motion
    for k, link in enumerate(desc.links, start=1):
        th, d, a, al = (float(theta[index[f"link{k}.{f}"]]) for f in ("theta", "d", "a", "alpha"))
        beta = float(theta[index[f"link{k}.beta"]]) if link.has_beta else 0.0
        if link.convention is Convention.DH:
            origins.append(carry @ rz(th) @ translation(0, 0, d))
            carry = translation(a, 0, 0) @ rx(al) @ ry(beta)
        else:
            origins.append(carry @ rx(al) @ ry(beta) @ translation(a, 0, 0) @ rz(th) @ translation(0, 0, d))
            carry = np.eye(4)
    return JointChain(
        base=pose_matrix(theta[desc.slices["base"]]),
        origins=tuple(origins),
        joints=tuple(link.joint for link in desc.links),
        flange=carry,
        tool=pose_matrix(theta[desc.slices["tool"]]),
    )


def motion(joint: JointType, q: float) -> Array:
    """M(q): about z for a revolute joint, along z for a prismatic one (mm, rad)."""
    if joint is JointType.REVOLUTE:
        return rz(q)
    if joint is JointType.PRISMATIC:
        return translation(0, 0, q)
    return np.eye(4)


def chain_pose(chain: JointChain, q: Array) -> Array:
    """world <- TCP at the moving joints' readings `q` (mm, rad): the product the formats are read with."""
    t = chain.base.copy()
    readings = iter(np.asarray(q, dtype=float))
    for origin, joint in zip(chain.origins, chain.joints, strict=True):
        t = t @ origin @ motion(joint, next(readings) if joint.moves else 0.0)
    return np.asarray(t @ chain.flange @ chain.tool, dtype=np.float64)
