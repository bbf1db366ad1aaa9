"""URDF in and out: a URDF chain becomes a serial stage; a calibrated serial model becomes a URDF.

Import (`document_from_urdf`). The URDF is parsed by yourdfpy; the joints on the path from `base_link` to
`tip_link` are read at their zero configuration as *lines in space* (a point and a direction per moving
joint), and the chain is re-described in modified DH (Craig) from those lines: frame k has its z axis on
joint k's axis and its x axis on the common normal towards joint k+1, and each link's four numbers follow
from two consecutive frames. Where two consecutive axes are parallel the common normal is not unique: it is
taken through the previous frame's origin (d = 0), and the link carries Hayati's beta (nominal 0).

Why this parameterisation and not one link per URDF joint keeping the URDF's `origin` (six numbers per
joint): the URDF's origins are a choice of frames, not geometry. Any chain of joint axes has this MDH form
exactly (URDF origins need not have a DH form; their lines always do), its FK equals the URDF's (tested to
1e-9 mm), fixed joints inside the chain disappear into the geometry of the lines, and the parameters are a
complete and minimal set: the structural identifiability is Everett–Hsu–Roth's 4R + 2P + 6 instead of a
rank-deficient 6 per joint whose redundant columns the fit would have to find and drop. What the URDF's
frames added goes into the base (base_link -> frame 0) and the tool (last frame -> tip_link).

Export (`urdf_from_description`). Any serial structure (DH or MDH links, fixed links) in its joint-origin form
(`models.formats.joint_chain`): each link becomes one URDF joint whose origin is the link's, with the motion about (or
along) its z axis; the base, the flange and the tool become fixed joints. Numbers are written with 17
significant digits, metres and radians as URDF wants: its FK equals the model's to round-off (tested).
"""

from __future__ import annotations

import functools
import io
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Any

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import JointType
from models.description.structure import Document
from models.errors import InvalidInput
from models.formats.joint_chain import joint_chain, rpy_of
from models.formats.urdf_tree import check_serial, check_size, tree_parents
from models.transforms import matrix_to_quaternion

MM_PER_M = 1000.0
PARALLEL_SIN = 1e-9
"""|z_k × z_k+1| below this: parallel axes (the common normal is then taken through the previous origin)."""
INTERSECT_MM = 1e-9
CONTINUOUS_TURNS = 10
CONTINUOUS_RANGE_DEG = (-360.0 * CONTINUOUS_TURNS, 360.0 * CONTINUOUS_TURNS)
"""A URDF `continuous` joint has no limits. A serial stage needs a range, so it gets ±10 turns: wide enough that
no reading a controller reports is refused (one turn refused a UR's wrist at 270°), finite for the solvers'
bounds and the workspace sampling (revolute kinematics are periodic, so the width costs nothing there). A revolute
joint's wider limits are cut to the same range, for the same reason (1e300 rad made a range of 5.7e301 degrees)."""
MAX_OFFSET_M = 1000.0
"""A joint origin's offset or a prismatic joint's limit (m) at most: a robot on a rail or a gantry spans tens of
metres; `<origin xyz="1e308 0 0">` overflowed to infinity in millimetres (an internal assertion, a 500)."""


# ---------------------------------------------------------------------------------------------- import
@dataclass(frozen=True)
class UrdfSource:
    """A URDF and the chain of it a robot is: what its calibrated export edits (`models.formats.urdf_calibrated`)."""

    urdf: str
    base_link: str
    tip_link: str


def urdf_chain(urdf: str, base_link: str, tip_link: str) -> list[Any]:
    """The URDF's joints (yourdfpy's) from `base_link` to `tip_link`, checked (`models.formats.urdf_tree`)."""
    return _chain(load_urdf(urdf), base_link, tip_link)


def load_urdf(urdf: str) -> Any:
    """yourdfpy's robot of a URDF text (links, joints, collision shapes), without its meshes or scene graphs:
    checked for size and refused as xacro first, and anything yourdfpy cannot read an `InvalidInput`."""
    import yourdfpy  # a heavy import (trimesh), needed only by URDF requests

    check_size(urdf)
    refuse_xacro(urdf)
    try:
        model = yourdfpy.URDF.load(
            io.BytesIO(urdf.encode()),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises lxml's and its own errors alike: all mean "not a URDF"
        raise InvalidInput(f"not a readable URDF: {exc}", field="urdf") from exc
    return model.robot


XACRO_ELEMENT = "<xacro:"
XACRO_SUBSTITUTIONS = ("${", "$(")


def _without_comments(text: str) -> str:
    """`text` less its `<!-- … -->` comments, in one pass (an unclosed one runs to the end, as in XML)."""
    kept, at = [], 0
    while (start := text.find("<!--", at)) >= 0:
        kept.append(text[at:start])
        end = text.find("-->", start + 4)
        at = len(text) if end < 0 else end + 3
    kept.append(text[at:])
    return "".join(kept)


def is_xacro(text: str) -> bool:
    """Whether `text` still holds xacro: an element of its namespace, or a `${…}` / `$(…)` substitution.
    Comments are left out, and the declaration alone is not xacro: the
    URDFs xacro writes keep `xmlns:xacro` on `<robot>` and the macros they came from in comments (TALOS's
    `talos_reduced.urdf` of example-robot-data is one)."""
    bare = _without_comments(text)
    return XACRO_ELEMENT in bare or any(s in bare for s in XACRO_SUBSTITUTIONS)


def refuse_xacro(text: str, field: str = "urdf") -> None:
    """A xacro file (a URDF macro, which ROS expands at launch) named as such with the command that expands it:
    read as a URDF it has no links at the top level, and the answer was "the URDF has no link ''"."""
    if is_xacro(text):
        raise InvalidInput(
            "this is a xacro file (a URDF with xacro macros), not a URDF: expand it first with "
            "`xacro robot.urdf.xacro > robot.urdf` (ROS 2: `ros2 run xacro xacro robot.urdf.xacro > robot.urdf`; "
            "ROS 1: `rosrun xacro xacro robot.urdf.xacro > robot.urdf`), passing the macro's arguments as name:=value, "
            "and send the URDF it writes",
            field=field,
        )


@functools.lru_cache(maxsize=32)
def urdf_joint_names(urdf: str, base_link: str, tip_link: str) -> tuple[str, ...]:
    """The moving joints' names from `base_link` to `tip_link`, in order: the robot's joints as ROS names them
    (`joint_1` …, `panda_joint1` …, `shoulder_pan_joint` …), which campaign files use as column names. Cached: a
    robot's files are read many times, its URDF parsed once."""
    return tuple(str(joint.name) for joint in urdf_chain(urdf, base_link, tip_link) if joint.type != "fixed")


def _chain(robot: Any, base_link: str, tip_link: str) -> list[Any]:
    links = {link.name for link in robot.links}
    for field, name in (("base_link", base_link), ("tip_link", tip_link)):
        if name not in links:
            raise InvalidInput(f"the URDF has no link {name!r}", field=field, value=name)
    by_child = tree_parents(robot)
    path: list[Any] = []
    at = tip_link
    while at != base_link:  # ends: tree_parents checked a tree, whose every walk up ends at its root
        joint = by_child.get(at)
        if joint is None:
            raise InvalidInput(
                f"{tip_link!r} is not below {base_link!r} in the URDF's tree (going up from it ends at the root "
                f"{at!r}): choose a base_link among the links above the tip",
                field="tip_link",
                value=tip_link,
            )
        path.append(joint)
        at = joint.parent
    path.reverse()
    for joint in path:
        check_serial(joint)
        _check_sizes(joint)
    if not any(joint.type != "fixed" for joint in path):
        raise InvalidInput("the chain between base_link and tip_link has no moving joint", field="tip_link")
    return path


def _check_sizes(joint: Any) -> None:
    """InvalidInput naming the joint and the element for a length beyond MAX_OFFSET_M (finite, checked before)."""
    offset = 0.0 if joint.origin is None else float(np.abs(np.asarray(joint.origin, dtype=float)[:3, 3]).max())
    lengths = [("<origin xyz>", offset)]
    if joint.type == "prismatic" and joint.limit is not None:
        lengths += [
            (f"<limit {side}>", abs(float(v)))
            for side in ("lower", "upper")
            if (v := getattr(joint.limit, side)) is not None
        ]
    for element, value in lengths:
        if not value <= MAX_OFFSET_M:  # `not <=`: NaN too
            raise InvalidInput(
                f"joint {joint.name!r} {element}: {value:g} m; at most {MAX_OFFSET_M:g} m is read (URDF lengths are "
                "metres)",
                field="urdf",
                value=joint.name,
                max=MAX_OFFSET_M,
            )


def origin_mm(joint: Any) -> Array:
    """A yourdfpy joint's origin (parent link <- joint frame at zero), in mm."""
    t = np.eye(4) if joint.origin is None else np.array(joint.origin, dtype=float)
    t[:3, 3] *= MM_PER_M
    return t


def _unit(v: Array) -> Array:
    return v / np.linalg.norm(v)


def _frame(z: Array, x: Array, origin: Array) -> Array:
    f = np.eye(4)
    f[:3, 0], f[:3, 2] = x, z
    f[:3, 1] = np.cross(z, x)
    f[:3, 3] = origin
    return f


def _perpendicular(z: Array, hint: Array) -> Array:
    """A unit vector ⟂ z, as close to `hint` as possible (another axis when hint is along z)."""
    for h in (hint, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
        v = h - z * float(z @ h)
        if np.linalg.norm(v) > 1e-6:
            return _unit(v)
    raise AssertionError("unreachable: two of the hints are independent")


def _normal(p1: Array, z1: Array, p2: Array, z2: Array, *, through: Array, x_hint: Array) -> tuple[Array, Array]:
    """(foot on line 1, unit x along the common normal from line 1 towards line 2)."""
    n = np.cross(z1, z2)
    if np.linalg.norm(n) < PARALLEL_SIN:
        c = p1 + z1 * float(z1 @ (through - p1))  # through the previous origin: d = 0
        off = p2 - c
        off -= z1 * float(z1 @ off)
        return c, (_unit(off) if np.linalg.norm(off) > INTERSECT_MM else _perpendicular(z1, x_hint))
    # closest points p1 + t1 z1, p2 + t2 z2
    b = float(z1 @ z2)
    w = p1 - p2
    d, e = float(z1 @ w), float(z2 @ w)
    den = 1.0 - b * b
    t1, t2 = (b * e - d) / den, (e - b * d) / den
    c1, c2 = p1 + t1 * z1, p2 + t2 * z2
    gap = c2 - c1
    x = _unit(gap) if np.linalg.norm(gap) > INTERSECT_MM else _unit(n)
    return c1, x


def _mdh_numbers(f_prev: Array, f_next: Array) -> tuple[float, float, float, float]:
    """(a, alpha, d, theta) with f_prev⁻¹ f_next = Rx(α) Tx(a) Rz(θ) Tz(d)."""
    t = np.linalg.solve(f_prev, f_next)
    r, p = t[:3, :3], t[:3, 3]
    alpha = math.atan2(-r[1, 2], r[2, 2])
    theta = math.atan2(-r[0, 1], r[0, 0])
    d = -math.sin(alpha) * p[1] + math.cos(alpha) * p[2]
    return float(p[0]), alpha, float(d), theta


def _pose_doc(t: Array) -> dict[str, list[float]]:
    q = matrix_to_quaternion(t[:3, :3])
    return {"position": [float(v) for v in t[:3, 3]], "orientation": [float(v) for v in q]}


def _limits(joint: Any) -> list[float]:
    if joint.type == "continuous" or joint.limit is None or joint.limit.lower is None or joint.limit.upper is None:
        if joint.type == "prismatic":
            raise InvalidInput(f"prismatic joint {joint.name!r} needs <limit lower upper>", field="urdf")
        return list(CONTINUOUS_RANGE_DEG)
    if joint.type == "prismatic":
        return [float(joint.limit.lower) * MM_PER_M, float(joint.limit.upper) * MM_PER_M]
    lo, hi = CONTINUOUS_RANGE_DEG
    lower, upper = math.degrees(float(joint.limit.lower)), math.degrees(float(joint.limit.upper))
    return [lower if math.isnan(lower) else max(lo, lower), upper if math.isnan(upper) else min(hi, upper)]


def document_from_urdf(urdf: str, base_link: str, tip_link: str) -> Document:
    """The robots.md document of the URDF chain from `base_link` to `tip_link` (see the module docstring)."""
    # Long on purpose: one pass down the chain, link by link: each joint's conversion needs the frame the
    # previous one left.
    path = urdf_chain(urdf, base_link, tip_link)
    # Joint frames in base_link at q = 0; the moving joints' axis lines.
    world = np.eye(4)
    axes: list[tuple[Array, Array, Any]] = []
    for joint in path:
        world = world @ origin_mm(joint)
        if joint.type != "fixed":
            axis = np.array([1.0, 0, 0]) if joint.axis is None else np.asarray(joint.axis, dtype=float)
            axis = axis / np.abs(axis).max()  # a direction: `1e200 1e200 0` overflowed its norm
            axes.append((world[:3, 3].copy(), _unit(world[:3, :3] @ axis), joint))
    tip = world
    # Frames 0..m (frame 0 on the first axis, fixed to base_link), each x on the normal to the next axis.
    p1, z1, _ = axes[0]
    x_hint = np.array([1.0, 0, 0])
    frames = []
    through = p1
    for k, (p, z, _) in enumerate(axes):
        if k + 1 < len(axes):
            p2, z2, _ = axes[k + 1]
            origin, x = _normal(p, z, p2, z2, through=through, x_hint=x_hint)
        else:
            origin = p + z * float(z @ (through - p))
            x = _perpendicular(z, x_hint)
        frames.append(_frame(z, x, origin))
        through, x_hint = origin, x
    frame0 = _frame(z1, _perpendicular(z1, np.array([1.0, 0, 0])), frames[0][:3, 3])
    links = []
    previous = frame0
    for f, (_, _, joint) in zip(frames, axes, strict=True):
        a, alpha, d, theta = _mdh_numbers(previous, f)
        kind = "prismatic" if joint.type == "prismatic" else "revolute"
        links.append(
            {
                "joint": kind,
                "a": a,
                "alpha": math.degrees(alpha),
                "d": d,
                "theta": math.degrees(theta),
                "range": _limits(joint),
            }
        )
        previous = f
    return {
        "base": _pose_doc(frame0),
        "tool": _pose_doc(np.asarray(np.linalg.solve(frames[-1], tip), dtype=np.float64)),
        "stages": [{"kind": "serial", "convention": "mdh", "links": links}],
    }


# ---------------------------------------------------------------------------------------------- export
def urdf_number(v: float) -> str:
    """Shortest text that reads back to the same double (no \"-0.0\")."""
    return repr(float(v) + 0.0)


def urdf_joint(root: ET.Element, name: str, kind: str, *, parent: str, child: str, origin: Array) -> ET.Element:
    joint = ET.SubElement(root, "joint", name=name, type=kind)
    ET.SubElement(joint, "parent", link=parent)
    ET.SubElement(joint, "child", link=child)
    roll, pitch, yaw = rpy_of(origin[:3, :3])
    xyz = " ".join(urdf_number(v / MM_PER_M) for v in origin[:3, 3])
    ET.SubElement(joint, "origin", xyz=xyz, rpy=f"{urdf_number(roll)} {urdf_number(pitch)} {urdf_number(yaw)}")
    return joint


def urdf_from_description(desc: RobotDescription, params: Array | None = None, *, name: str = "robot") -> str:
    """A URDF of a serial structure with the values of `params` (internal units; default nominal).

    Links are `world`, `base`, `link1` … `link{n}`, `tcp`; joints `base_joint`, `joint1` … `joint{n}`
    (moving or fixed as the links), `flange_joint` and `tool_joint`. `name` is escaped by the XML writer.
    """
    chain = joint_chain(desc, params, what="a URDF")
    root = ET.Element("robot", name=name)
    for link_name in ("world", "base", *(f"link{k}" for k in range(1, len(desc.links) + 1)), "flange", "tcp"):
        ET.SubElement(root, "link", name=link_name)
    urdf_joint(root, "base_joint", "fixed", parent="world", child="base", origin=chain.base)
    parent = "base"
    for k, (link, origin) in enumerate(zip(desc.links, chain.origins, strict=True), start=1):
        kind = {JointType.REVOLUTE: "revolute", JointType.PRISMATIC: "prismatic", JointType.FIXED: "fixed"}[link.joint]
        joint = urdf_joint(root, f"joint{k}", kind, parent=parent, child=f"link{k}", origin=origin)
        if link.joint.moves:
            ET.SubElement(joint, "axis", xyz="0 0 1")
            scale = MM_PER_M if link.joint is JointType.PRISMATIC else 1.0
            ET.SubElement(
                joint,
                "limit",
                lower=urdf_number(link.joint_min / scale),
                upper=urdf_number(link.joint_max / scale),
                effort="0",
                velocity="0",
            )
        parent = f"link{k}"
    urdf_joint(root, "flange_joint", "fixed", parent=parent, child="flange", origin=chain.flange)
    urdf_joint(root, "tool_joint", "fixed", parent="flange", child="tcp", origin=chain.tool)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True)
