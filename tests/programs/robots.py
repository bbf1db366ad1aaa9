"""Robots as their makers describe them, for the controller-frame tests: a UR10e from a `default_kinematics.yaml`
shaped as ur_description ships it, a UR10e URDF shaped as ur_description's xacro expands it (base_link, the
turned base_link_inertia, ROS-Industrial's `base`), a KUKA KR 6-like URDF shaped as kuka_experimental's (A1 about
−z, `base` = $ROBROOT) and an ABB IRB 140-like one shaped as abb_experimental's. Written here from the vendors'
published dimensions; no file is copied.

Beside each, an independent forward kinematics in numpy straight from the text's joint origins (URDF: origin ·
rotation about the joint's axis; UR file: origin · Rz(q)), and one of a modified-DH parameter vector, so that the
tests compare the product's answers with numbers it did not compute."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import yaml

from harness.programs import UR10E_KINEMATICS
from models._types import Array
from models.description.robot import RobotDescription

_UR_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3")
_UR_LINKS = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link", "wrist_3_link")


def _joint(name: str, parent: str, child: str, xyz: str, rpy: str = "0 0 0", axis: str | None = None) -> str:
    kind = "fixed" if axis is None else "revolute"
    moving = (
        ""
        if axis is None
        else f'\n    <axis xyz="{axis}"/>\n    <limit lower="-6.2832" upper="6.2832" effort="150" velocity="2.1"/>'
    )
    return (
        f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
        f'    <origin xyz="{xyz}" rpy="{rpy}"/>{moving}\n  </joint>\n'
    )


def _urdf(name: str, links: list[str], joints: list[str]) -> str:
    body = "".join(f'  <link name="{link}"/>\n' for link in links) + "".join(joints)
    return f'<?xml version="1.0" ?>\n<robot name="{name}">\n{body}</robot>\n'


def _ur10e_urdf() -> str:
    """ur_description's expansion: base_link -> base_link_inertia (π about z) -> the file's six origins;
    base_link -> `base` (π about z, UR's Base); wrist_3 -> flange -> tool0."""
    doc = yaml.safe_load(UR10E_KINEMATICS)["kinematics"]
    parents = ("base_link_inertia", *_UR_LINKS[:-1])
    joints = [
        _joint("base_link-base_link_inertia", "base_link", "base_link_inertia", "0 0 0", "0 0 3.141592653589793"),
        _joint("base_link-base_fixed_joint", "base_link", "base", "0 0 0", "0 0 3.141592653589793"),
    ]
    for joint, parent, child, segment in zip(_UR_JOINTS, parents, _UR_LINKS, doc.values(), strict=False):
        xyz = f"{segment['x']} {segment['y']} {segment['z']}"
        rpy = f"{segment['roll']} {segment['pitch']} {segment['yaw']}"
        joints.append(_joint(f"{joint}_joint", parent, child, xyz, rpy, axis="0 0 1"))
    joints.append(
        _joint("wrist_3-flange", "wrist_3_link", "flange", "0 0 0", "0 -1.5707963267948966 -1.5707963267948966")
    )
    joints.append(_joint("flange-tool0", "flange", "tool0", "0 0 0", "1.5707963267948966 0 1.5707963267948966"))
    links = ["base_link", "base_link_inertia", "base", *_UR_LINKS, "flange", "tool0"]
    return _urdf("ur10e", links, joints)


def _industrial_urdf(name: str, joint_names: Sequence[str], origins: Sequence[str], axes: Sequence[str]) -> str:
    """ROS-Industrial's six-axis layout, which both vendors' packages follow: base_link -> `base` identity (the
    controller's base frame), link_1 … link_6 by the joints `joint_names` at their `origins` (m) about their
    `axes`, and tool0 on link_6 turned so its z points out of the flange."""
    links = [f"link_{k}" for k in range(1, 7)]
    joints = [_joint("base_link-base", "base_link", "base", "0 0 0")]
    for joint, parent, child, xyz, axis in zip(
        joint_names, ["base_link", *links[:-1]], links, origins, axes, strict=True
    ):
        joints.append(_joint(joint, parent, child, xyz, axis=axis))
    joints.append(_joint(f"{joint_names[-1]}-tool0", "link_6", "tool0", "0 0 0", "0 1.5707963267948966 0"))
    return _urdf(name, ["base_link", "base", *links, "tool0"], joints)


def _kr6_urdf() -> str:
    """kuka_experimental's shape: A1 about −z 400 mm up, A4 and A6 about −x, base_link -> `base` identity
    ($ROBROOT), tool0 turned so its z points out of the flange."""
    return _industrial_urdf(
        "kuka_kr6_like",
        [f"joint_a{k}" for k in range(1, 7)],
        origins=("0 0 0.400", "0.025 0 0", "0.455 0 0", "0 0 0.035", "0.420 0 0", "0.080 0 0"),
        axes=("0 0 -1", "0 1 0", "0 1 0", "-1 0 0", "0 1 0", "-1 0 0"),
    )


def _irb140_urdf() -> str:
    """abb_experimental's shape for an IRB 140: 352 mm to axis 2, 70 mm out, 360 mm arm, 380 mm to the wrist,
    65 mm flange; base_link -> `base` identity (ABB's base frame)."""
    return _industrial_urdf(
        "abb_irb140_like",
        [f"joint_{k}" for k in range(1, 7)],
        origins=("0 0 0", "0.070 0 0.352", "0 0 0.360", "0.190 0 0", "0.190 0 0", "0.065 0 0"),
        axes=("0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0"),
    )


def _rot(axis: Array, angle: float) -> Array:
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    out = np.eye(4)
    out[:3, :3] = np.eye(3) + math.sin(angle) * kx + (1 - math.cos(angle)) * kx @ kx
    return out


def _origin(xyz: list[float], rpy: list[float]) -> Array:
    """URDF's origin: translation (m -> mm) · Rz(yaw) Ry(pitch) Rx(roll)."""
    r = _rot(np.array([0, 0, 1.0]), rpy[2]) @ _rot(np.array([0, 1.0, 0]), rpy[1]) @ _rot(np.array([1.0, 0, 0]), rpy[0])
    r[:3, 3] = np.asarray(xyz, dtype=float) * 1000.0
    return r


@dataclass(frozen=True)
class UrdfFk:
    """Forward kinematics of a URDF chain from its text: controller frame <- tip at joints q (mm)."""

    origins: tuple[Array, ...]
    axes: tuple[Array | None, ...]
    controller_from_root: Array

    def __call__(self, q: Array) -> Array:
        t = np.asarray(np.linalg.inv(self.controller_from_root), dtype=float)
        k = 0
        for origin, axis in zip(self.origins, self.axes, strict=True):
            t = t @ origin
            if axis is not None:
                t = t @ _rot(axis, float(q[k]))
                k += 1
        return t


def urdf_fk(urdf: str, base_link: str, tip_link: str, controller: str) -> UrdfFk:
    root = ET.fromstring(urdf)
    by_child = {j.find("child").get("link"): j for j in root.iter("joint")}  # type: ignore[union-attr]

    def parsed(joint: ET.Element) -> tuple[Array, Array | None]:
        o = joint.find("origin")
        assert o is not None
        origin = _origin(
            [float(v) for v in o.get("xyz", "0 0 0").split()], [float(v) for v in o.get("rpy", "0 0 0").split()]
        )
        a = joint.find("axis")
        axis = None if joint.get("type") == "fixed" else np.array([float(v) for v in a.get("xyz").split()])  # type: ignore[union-attr]
        return origin, axis

    chain: list[ET.Element] = []
    at = tip_link
    while at != base_link:
        joint = by_child[at]
        chain.append(joint)
        at = joint.find("parent").get("link")  # type: ignore[union-attr,assignment]
    chain.reverse()
    parts = [parsed(j) for j in chain]
    controller_from_root = np.eye(4) if controller == base_link else parsed(by_child[controller])[0]
    return UrdfFk(tuple(p[0] for p in parts), tuple(p[1] for p in parts), controller_from_root)


def ur_file_fk(text: str) -> UrdfFk:
    """UR's file read as the driver does: origin_k · Rz(q_k), then the flange and tool0 turns, in the file's frame."""
    doc = yaml.safe_load(text)["kinematics"]
    origins = [
        _origin([s["x"], s["y"], s["z"]], [s["roll"], s["pitch"], s["yaw"]]) for k, s in doc.items() if k != "hash"
    ]
    flange = _origin([0, 0, 0], [0, -math.pi / 2, -math.pi / 2]) @ _origin([0, 0, 0], [math.pi / 2, 0, math.pi / 2])
    z = np.array([0, 0, 1.0])
    return UrdfFk((*origins, flange), (z, z, z, z, z, z, None), np.eye(4))


def _pose6(v: Array) -> Array:
    out = _rot(v[3:6], float(np.linalg.norm(v[3:6]))) if np.linalg.norm(v[3:6]) > 0 else np.eye(4)
    out[:3, 3] = v[:3]
    return out


def mdh_fk(desc: RobotDescription, theta: Array, q: Array) -> Array:
    """World <- TCP of a serial MDH description at joints q, written out: base · Π Rx(α) Ry(β) Tx(a) Rz(θ+q) Tz(d)
    · tool, reading the parameter vector in robots.md's order (base, per link θ d a α [β], tool)."""
    t = _pose6(theta[0:6])
    at = 6
    x, y, zz = np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    for k, link in enumerate(desc.links):
        th, d, a, alpha = theta[at : at + 4]
        beta = theta[at + 4] if link.has_beta else 0.0
        at += 5 if link.has_beta else 4
        shift_a, shift_d = np.eye(4), np.eye(4)
        shift_a[0, 3], shift_d[2, 3] = a, d
        t = t @ _rot(x, alpha) @ _rot(y, beta) @ shift_a @ _rot(zz, th + q[k]) @ shift_d
    out: Array = t @ _pose6(theta[at : at + 6])
    return out


@dataclass(frozen=True)
class Maker:
    name: str
    urdf: str
    base_link: str
    tip_link: str
    controller: str
    """The link that is the controller's base frame."""
    box_deg: tuple[tuple[float, float], ...]
    """Joint ranges the targets are taught in: away from the arm's singularities."""


UR10E_BOX: tuple[tuple[float, float], ...] = ((-40, 40), (-120, -60), (50, 110), (-120, -60), (60, 120), (-40, 40))
MAKERS = {
    "ur10e-urdf": Maker("ur10e-urdf", _ur10e_urdf(), "base_link", "tool0", "base", UR10E_BOX),
    "kr6-urdf": Maker(
        "kr6-urdf",
        _kr6_urdf(),
        "base_link",
        "tool0",
        "base",
        ((-40, 40), (-60, -20), (30, 80), (-40, 40), (30, 80), (-40, 40)),
    ),
    "irb140-urdf": Maker(
        "irb140-urdf",
        _irb140_urdf(),
        "base_link",
        "tool0",
        "base",
        ((-40, 40), (-30, 30), (-30, 30), (-40, 40), (30, 80), (-40, 40)),
    ),
}
