"""UR's kinematics file: the `calibration.yaml` that Universal Robots' ROS drivers read, out and in.

`ur_description` builds a UR arm from six joint origins read from this file (its `kinematics_parameters_file`):
joint k's origin is `shoulder`, `upper_arm`, `forearm`, `wrist_1`, `wrist_2`, `wrist_3` in that order, each
`{x, y, z, roll, pitch, yaw}` in metres and radians (the xacro puts them into `<origin xyz rpy>`, so the
angles are URDF's fixed-axis roll, pitch, yaw), every joint turns about its own z axis, and the chain starts at
the controller's base frame (`base_link_inertia`, which is `base_link` turned by π about z, as the ROS-I `base`
frame is). The tool flange `tool0` coincides with `wrist_3_link` (the xacro's `flange` and `tool0` turns cancel).
`hash` names the calibration; the driver compares it with the controller's and warns on a difference.

So the file is the joint-origin form of a 6R arm (`models.formats.joint_chain`, which puts a DH link's d and θ into its
own origin as `ur_calibration` does) with nothing after the last joint: the last link's a6, α6 (zero on a UR)
stay with the TCP, which a controller keeps apart from the arm. `ur_calibration` writes its angles with
Eigen's `eulerAngles(0, 1, 2)`, i.e. R = Rx·Ry·Rz, and the xacro reads them as URDF's Rz·Ry·Rx: the two agree
on a factory file's rotations (quarter turns about one axis) but not in general. This module writes and
reads what the xacro reads, URDF's convention, so the URDF the driver builds has the calibrated FK.
"""

from __future__ import annotations

import hashlib
import math
import re
import reprlib
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import yaml

from models._types import Array
from models.description.serial_chain import JointType
from models.errors import InvalidInput
from models.formats.joint_chain import JointChain, rpy_matrix, rpy_of, translation
from models.formats.urdf import MM_PER_M, urdf_joint, urdf_number

SEGMENTS = ("shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3")
"""The file's keys, joint 1 to 6 (ur_description's names)."""
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint", "wrist_3_joint")
LINKS = ("shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link", "wrist_3_link")
BASE_LINK = "base_link_inertia"
"""The frame the file's first origin starts from: the controller's base frame."""
TIP_LINK = "tool0"
RANGES_DEG = ((-360.0, 360.0), (-360.0, 360.0), (-180.0, 180.0), (-360.0, 360.0), (-360.0, 360.0), (-360.0, 360.0))
"""ur_description's joint limits (the elbow is held to half a turn there, its physical range)."""
KEYS = ("x", "y", "z", "roll", "pitch", "yaw")
MAX_OFFSET_M = 100.0
"""A joint origin's offset (m): UR arms' are under 1.3 m; beyond 100 m a file is wrong (mm for m), and 1e300 m
would overflow the import's geometry."""
MAX_CHARS = 64_000
"""A kinematics file is about 600 characters; the bound keeps a hostile YAML's parsing short."""
MAX_FLOW_DEPTH = 16
"""Nesting of flow collections (`[`, `{`) in a kinematics file, at most, counted before PyYAML reads it: a file
has none (its block mappings nest 3 deep), a one-line flow form at most 3. PyYAML composes nesting recursively:
30 000 `[` took 0.84 s of CPU here (5.8 s on the loaded probe machine) to reach its RecursionError. Block nesting
needs indentation or a `- ` per level, which MAX_CHARS keeps cheap (30 000 `- `: 0.01 s)."""
_COMMENT = re.compile(r"(?:^|(?<=\s))#[^\n\r]*", re.MULTILINE)
_NOT_FLOW = str.maketrans("", "", "".join(chr(c) for c in range(128) if chr(c) not in "[]{}"))


@dataclass(frozen=True)
class UrChain:
    """A 6R arm as UR's file holds it: world <- TCP = world_from_root · Π_k (origins[k] · Rz(q_k)) · tail (mm)."""

    world_from_root: Array
    origins: tuple[Array, ...]
    tail: Array


def require_6r(joints: Sequence[JointType]) -> None:
    """InvalidInput (field `format`) unless the moving joints are six, all revolute."""
    moving = [j for j in joints if j.moves]
    if len(moving) != 6 or any(j is not JointType.REVOLUTE for j in moving):
        kinds = ", ".join(j.value for j in moving)
        raise InvalidInput(
            f"UR's kinematics file describes a 6R arm (six revolute joints); this robot's joints are "
            f"{len(moving)} ({kinds})",
            field="format",
            reason="not_6r",
        )


def ur_chain(chain: JointChain) -> UrChain:
    """The file's six origins of a serial robot (fixed links folded into the next origin); InvalidInput
    (field `format`) unless it is a 6R arm."""
    require_6r(chain.joints)
    origins: list[Array] = []
    pending = np.eye(4)  # the fixed links since the last joint
    for origin, joint in zip(chain.origins, chain.joints, strict=True):
        if joint.moves:
            origins.append(pending @ origin)
            pending = np.eye(4)
        else:
            pending = pending @ origin
    # After the sixth joint: fixed links, the flange and the tool, all on the last link (the TCP, to the file).
    return UrChain(world_from_root=chain.base, origins=tuple(origins), tail=pending @ chain.flange @ chain.tool)


def _number(v: float) -> str:
    """Round-trip digits (as yaml-cpp writes them), and a YAML 1.1 float: PyYAML, which xacro reads the file
    with, takes `1e-05` for a string; `1.0e-05` is a number to every YAML reader."""
    text = urdf_number(v)
    mantissa, e, exponent = text.partition("e")
    return f"{mantissa}.0e{exponent}" if e and "." not in mantissa else text


YAML12_NUMBER = re.compile(r"[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?")
"""A number to YAML 1.2 (yaml-cpp, which ur_calibration writes with) that YAML 1.1 (PyYAML) reads as a string:
`1e-05`, `2E3`."""


def kinematics_hash(values: Sequence[float]) -> str:
    """`calib_` and 19 digits, the shape of UR's hash, from these numbers. UR's own is the controller's checksum
    of its DH table; a calibration made here cannot have it, and the driver's warning about a difference is then
    right: the controller still runs its own kinematics."""
    digest = hashlib.sha256(",".join(_number(v) for v in values).encode()).digest()
    return f"calib_{int.from_bytes(digest[:8], 'big') % 10**19:019d}"


def kinematics_yaml(origins: Sequence[Array], header: Sequence[str]) -> str:
    """The file's text: `header` as comment lines, then `kinematics:` with the six origins (mm in) in metres and
    URDF's roll, pitch, yaw, and `hash`."""
    lines = [f"# {line}" if line else "#" for line in header]
    lines.append("kinematics:")
    values: list[float] = []
    for name, origin in zip(SEGMENTS, origins, strict=True):
        numbers = [*(origin[:3, 3] / MM_PER_M), *rpy_of(origin[:3, :3])]
        values += numbers
        lines.append(f"  {name}:")
        lines += [f"    {key}: {_number(v)}" for key, v in zip(KEYS, numbers, strict=True)]
    lines.append(f"  hash: {kinematics_hash(values)}")
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------------------------------------- in
def _load(text: str, field: str) -> Any:
    if len(text) > MAX_CHARS:
        raise InvalidInput(
            f"{field}: {len(text)} characters; a kinematics file has under a thousand (at most {MAX_CHARS})",
            field=field,
            reason="too_large",
            max=MAX_CHARS,
        )
    depth = flow_depth(text)
    if depth > MAX_FLOW_DEPTH:
        raise InvalidInput(
            f"{field}: brackets nested {depth} deep; a kinematics file nests at most {MAX_FLOW_DEPTH} (it has none)",
            field=field,
            reason="too_deep",
            max=MAX_FLOW_DEPTH,
        )
    try:
        return yaml.safe_load(text)
    except (yaml.YAMLError, ValueError) as exc:  # PyYAML's constructors raise ValueError (a 13th month, !!int x)
        raise InvalidInput(f"{field}: not readable YAML: {exc}", field=field, reason="not_yaml") from exc
    except RecursionError as exc:  # PyYAML composes nesting recursively: 30 000 "[" overflow its stack
        raise InvalidInput(
            f"{field}: nested too deeply to be a kinematics file", field=field, reason="not_yaml"
        ) from exc


def flow_depth(text: str) -> int:
    """The deepest nesting of `[` and `{` outside comments (running count; a closing bracket in a quoted string
    only lowers it). Linear: comments cut by one regex, the brackets kept by `str.translate`."""
    depth = deepest = 0
    for c in _COMMENT.sub("", text).translate(_NOT_FLOW):
        if c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    return deepest


def _finite(v: float) -> bool:
    try:
        return math.isfinite(float(v))
    except OverflowError:  # an integer of 400 digits
        return False


def _segment(raw: Any, where: str) -> Array:
    if not isinstance(raw, dict):
        raise InvalidInput(f"{where}: expected a mapping of {', '.join(KEYS)}", field=where)
    unknown = sorted(reprlib.repr(k) for k in raw if k not in KEYS)
    if unknown:
        raise InvalidInput(f"{where}: unknown key {unknown[0]}; the keys are {', '.join(KEYS)}", field=where)
    numbers = []
    for key in KEYS:
        v = raw.get(key)
        if isinstance(v, str) and YAML12_NUMBER.fullmatch(v):
            v = float(v)
        # YAML reads `yes` as a boolean, which is an int to Python: refused like any non-number.
        if isinstance(v, bool) or not isinstance(v, int | float) or not _finite(v):
            shown = "missing" if key not in raw else reprlib.repr(v)  # bounded: YAML aliases can nest a huge value
            raise InvalidInput(f"{where}.{key}: expected a finite number, got {shown}", field=f"{where}.{key}")
        if key in "xyz" and abs(float(v)) > MAX_OFFSET_M:
            raise InvalidInput(
                f"{where}.{key}: {float(v)} m; a joint's offset on an arm is under {MAX_OFFSET_M:g} m (metres?)",
                field=f"{where}.{key}",
                reason="out_of_range",
                min=-MAX_OFFSET_M,
                max=MAX_OFFSET_M,
            )
        numbers.append(float(v))
    x, y, z, roll, pitch, yaw = numbers
    return translation(x * MM_PER_M, y * MM_PER_M, z * MM_PER_M) @ rpy_matrix(roll, pitch, yaw)


def read_kinematics(text: str, field: str = "document") -> tuple[Array, ...]:
    """The six joint origins (mm) of a kinematics file; InvalidInput naming the key for anything else."""
    doc = _load(text, field)
    if not isinstance(doc, dict) or not isinstance(doc.get("kinematics"), dict):
        raise InvalidInput(f"{field}: expected a mapping with the key 'kinematics'", field=f"{field}.kinematics")
    kin = doc["kinematics"]
    unknown = sorted((k for k in kin if k not in (*SEGMENTS, "hash")), key=str)
    if unknown:  # YAML keys are scalars (a sequence key is unhashable, a YAMLError): str() is short
        raise InvalidInput(
            f"{field}.kinematics: unknown key {reprlib.repr(unknown[0])}; the keys are {', '.join(SEGMENTS)} and hash",
            field=f"{field}.kinematics.{str(unknown[0])[:100]}",
        )
    missing = [name for name in SEGMENTS if name not in kin]
    if missing:
        raise InvalidInput(
            f"{field}.kinematics: missing {', '.join(missing)}; a UR arm has all six joints",
            field=f"{field}.kinematics.{missing[0]}",
        )
    return tuple(_segment(kin[name], f"{field}.kinematics.{name}") for name in SEGMENTS)


def urdf_of_kinematics(origins: Sequence[Array], name: str = "ur") -> str:
    """The kinematic URDF ur_description builds from these origins: `base_link_inertia` to `wrist_3_link`, the
    joints about z with ur_description's names and limits, then its `flange` and `tool0`."""
    root = ET.Element("robot", name=name)
    for link in (BASE_LINK, *LINKS, "flange", TIP_LINK):
        ET.SubElement(root, "link", name=link)
    parents = (BASE_LINK, *LINKS[:-1])
    for joint, parent, child, origin, (lo, hi) in zip(JOINTS, parents, LINKS, origins, RANGES_DEG, strict=True):
        element = urdf_joint(root, joint, "revolute", parent=parent, child=child, origin=origin)
        ET.SubElement(element, "axis", xyz="0 0 1")
        lower, upper = _number(math.radians(lo)), _number(math.radians(hi))
        ET.SubElement(element, "limit", lower=lower, upper=upper, effort="0", velocity="0")
    urdf_joint(
        root,
        "wrist_3-flange",
        "fixed",
        parent=LINKS[-1],
        child="flange",
        origin=rpy_matrix(0, -math.pi / 2, -math.pi / 2),
    )
    urdf_joint(
        root, "flange-tool0", "fixed", parent="flange", child=TIP_LINK, origin=rpy_matrix(math.pi / 2, 0, math.pi / 2)
    )
    ET.indent(root)
    return ET.tostring(root, encoding="unicode", xml_declaration=True)
