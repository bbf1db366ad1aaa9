"""An imported URDF with its calibrated joint origins: the same document, only the chain's moving joints' `<origin>`.

A URDF robot is calibrated as the MDH chain `models.formats.urdf` reads from the URDF's joint axes. Each MDH frame k
(z on joint k's axis) and the URDF's joint frame F_j of the same joint are fixed to the same link, so they
differ by a constant C_k = (J_k nominal)⁻¹ · F_j nominal, a turn about and a shift along the axis (both put z,
or the URDF's `axis`, on the one line). The calibrated joint frame keeps that relation to its link:
F_j calibrated = J_k calibrated · C_k. Every link frame, mesh, inertia and child frame then moves with its
calibrated joint as it did with the nominal one, and the URDF's FK is the calibrated model's.

The fixed joints of the chain keep their origins; each moving joint's new origin is its calibrated frame seen
from its parent link (itself placed by the calibrated joints before it and the fixed origins between). Where
the calibration moved what no joint origin holds — the robot's place in the measurement frame (the base) and
the TCP on the last link (the tool) — `UrdfCalibration` says so: `world_from_base_link` and `tip_to_tcp`.

The document is edited as text (`splice_origins`): expat gives each start tag's byte offset, and only the
`<origin .../>` tags of those joints are rewritten, so comments, namespaces, `<gazebo>`, `<transmission>` and
the formatting stay byte for byte.
"""

from __future__ import annotations

import math
import xml.parsers.expat
from dataclasses import dataclass, field

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.joint_chain import joint_chain, rpy_of
from models.formats.ur_kinematics import UrChain
from models.formats.urdf import MM_PER_M, document_from_urdf, origin_mm, urdf_chain, urdf_number
from models.transforms import rotvec_to_matrix_np


@dataclass(frozen=True)
class UrdfCalibration:
    """The calibrated origins of the chain's moving joints (mm, parent link <- joint frame), their joint frames
    and axes in `base_link` at zero, and the frames the URDF cannot hold."""

    origins: dict[str, Array]
    frames: tuple[Array, ...]
    axes: tuple[Array, ...]
    world_from_base_link: Array
    """The measurement frame (world) <- base_link: the calibrated base with the URDF's base_link <- frame 0."""
    tip: Array
    """base_link <- tip_link, calibrated, at zero."""
    tip_to_tcp: Array
    """tip_link -> the calibrated TCP."""

    def ur_chain(self) -> UrChain:
        """UR's six origins from base_link: between the joint frames turned so that z is each joint's axis (the
        identity turn where the URDF's axis is z already, as ur_description's are), then the last frame -> TCP."""
        previous, origins = np.eye(4), []
        for frame, axis in zip(self.frames, self.axes, strict=True):
            turned = frame @ z_onto(axis)
            origins.append(_solve(previous, turned))
            previous = turned
        tail = _solve(previous, self.tip @ self.tip_to_tcp)
        return UrChain(world_from_root=self.world_from_base_link, origins=tuple(origins), tail=tail)


def _solve(a: Array, b: Array) -> Array:
    """a⁻¹ · b."""
    return np.asarray(np.linalg.solve(a, b), dtype=np.float64)


def _products(base: Array, origins: tuple[Array, ...]) -> list[Array]:
    out, t = [], base
    for origin in origins:
        t = t @ origin
        out.append(t)
    return out


def calibrate_urdf(urdf: str, base_link: str, tip_link: str, desc: RobotDescription, params: Array) -> UrdfCalibration:
    """The calibrated joint origins of a URDF whose chain `desc` was imported from (values `params`)."""
    path = urdf_chain(urdf, base_link, tip_link)
    nominal = description_from_document(document_from_urdf(urdf, base_link, tip_link))
    if [link.token for link in nominal.links] != [link.token for link in desc.links]:
        raise InvalidInput(
            "the stored URDF no longer reads as this robot's chain; export it with ?format=dh", field="format"
        )
    chain_nom, chain_cal = joint_chain(nominal), joint_chain(desc, params, what="a URDF")
    b_u = chain_nom.base  # base_link <- frame 0, as the import placed it
    j_nom, j_cal = _products(b_u, chain_nom.origins), _products(b_u, chain_cal.origins)
    frame_nom, frame, moving = np.eye(4), np.eye(4), iter(range(len(j_nom)))
    origins: dict[str, Array] = {}
    frames, axes = [], []
    for joint in path:
        frame_nom = frame_nom @ origin_mm(joint)
        if joint.type == "fixed":
            frame = np.asarray(frame @ origin_mm(joint), dtype=np.float64)
            continue
        k = next(moving)
        f_cal = j_cal[k] @ _solve(j_nom[k], frame_nom)  # J_k calibrated · C_k
        origins[joint.name] = _solve(frame, f_cal)
        frame = np.asarray(f_cal, dtype=np.float64)
        frames.append(f_cal)
        axes.append(np.array([1.0, 0, 0]) if joint.axis is None else np.asarray(joint.axis, dtype=float))
    tcp = (j_cal[-1] if j_cal else b_u) @ chain_cal.flange @ chain_cal.tool
    return UrdfCalibration(
        origins=origins,
        frames=tuple(frames),
        axes=tuple(axes),
        world_from_base_link=chain_cal.base @ np.linalg.inv(b_u),
        tip=frame,
        tip_to_tcp=_solve(frame, tcp),
    )


def z_onto(axis: Array) -> Array:
    """A rotation (4x4) taking z onto the unit `axis`: the identity for z, a half turn about x for -z."""
    a = axis / np.linalg.norm(axis)
    z = np.array([0.0, 0, 1])
    turn = np.cross(z, a)
    t = np.eye(4)
    if np.linalg.norm(turn) < 1e-12:
        return t if a[2] > 0 else np.diag([1.0, -1.0, -1.0, 1.0])
    angle = math.atan2(float(np.linalg.norm(turn)), float(z @ a))
    t[:3, :3] = rotvec_to_matrix_np(turn / np.linalg.norm(turn) * angle)
    return t


def origin_attributes(origin: Array) -> str:
    """`xyz="…" rpy="…"` of an origin given in mm: metres and URDF's roll, pitch, yaw, round-trip digits."""
    xyz = " ".join(urdf_number(v / MM_PER_M) for v in origin[:3, 3])
    rpy = " ".join(urdf_number(v) for v in rpy_of(origin[:3, :3]))
    return f'xyz="{xyz}" rpy="{rpy}"'


def _tag_end(data: bytes, start: int) -> int:
    """The offset just past the `>` closing the start tag at `start` (quotes may hold `>`)."""
    quote = 0
    for i in range(start, len(data)):
        c = data[i]
        if quote:
            quote = 0 if c == quote else quote
        elif c in (0x22, 0x27):
            quote = c
        elif c == 0x3E:
            return i + 1
    raise InvalidInput("the stored URDF ends inside a tag", field="urdf")


@dataclass
class _Splice:
    """What the expat pass collects: the byte edits, and the joint whose `<origin>` it is looking for."""

    data: bytes
    origins: dict[str, Array]
    edits: list[tuple[int, int, bytes]] = field(default_factory=list)
    depth: int = 0
    root_at: int = -1
    joint: str | None = None
    after: int = 0
    seen_origin: bool = False

    def origin_tag(self, close: bytes) -> bytes:
        assert self.joint is not None
        return f"<origin {origin_attributes(self.origins[self.joint])}".encode() + close

    def start(self, at: int, name: str, attrs: dict[str, str]) -> None:
        if self.depth == 0:
            self.root_at = at
        if self.depth == 1 and name == "joint" and attrs.get("name") in self.origins:
            self.joint, self.after, self.seen_origin = attrs["name"], _tag_end(self.data, at), False
        elif self.depth == 2 and name == "origin" and self.joint is not None:
            end = _tag_end(self.data, at)
            close = b"/>" if self.data[: end - 1].endswith(b"/") else b">"  # keep an </origin> valid
            self.edits.append((at, end, self.origin_tag(close)))
            self.seen_origin = True
        self.depth += 1

    def end(self, name: str) -> None:
        self.depth -= 1
        if self.depth == 1 and name == "joint" and self.joint is not None:
            if not self.seen_origin:  # no <origin> is the identity: the calibrated one goes first in the joint
                self.edits.append((self.after, self.after, self.origin_tag(b"/>")))
            self.joint = None


def splice_origins(urdf: str, origins: dict[str, Array], comment: str) -> str:
    """`urdf` with the `<origin>` of each joint in `origins` (mm) rewritten (inserted where it had none), and
    `comment` before the root element; every other byte as it was."""
    data = urdf.encode()
    parser = xml.parsers.expat.ParserCreate(encoding="utf-8")  # the text is a str: its bytes are UTF-8
    splice = _Splice(data, origins)
    parser.StartElementHandler = lambda name, attrs: splice.start(parser.CurrentByteIndex, name, attrs)
    parser.EndElementHandler = splice.end
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise InvalidInput(f"the stored URDF does not parse: {exc}", field="urdf") from exc
    while "--" in comment:  # XML forbids "--" in a comment (a robot named "cell--3")
        comment = comment.replace("--", "- -")
    edits = [*splice.edits, (splice.root_at, splice.root_at, f"<!-- {comment} -->\n".encode())]
    out = data
    for begin, stop, new in sorted(edits, key=lambda e: e[0], reverse=True):
        out = out[:begin] + new + out[stop:]
    return out.decode()


def frame_text(t: Array) -> str:
    """`x y z (mm) roll pitch yaw (deg)` of a transform, round-trip digits: a header a program can read."""
    numbers = [*(float(v) for v in t[:3, 3]), *(math.degrees(v) for v in rpy_of(t[:3, :3]))]
    return " ".join(urdf_number(v) for v in numbers)
