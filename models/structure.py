"""The description document of `shared/spec/robots.md`: a robot of any structure, read and written.

`description_from_document` validates a document (JSON-shaped: mm and degrees, quaternions `[w, x, y, z]`)
and builds the frozen `RobotDescription`; every rule of robots.md that a document breaks raises
`InvalidInput` naming the field by its path (`stages[1].links[2].range`). `description_document` writes the
document back, with the nominal values of the description or with a calibrated parameter vector; the result
is accepted by `description_from_document` again.

Nothing of a document reaches generated code: the structure key (`RobotDescription.structure`) is made of
enumerations and counts, and the numbers are inputs of the compiled Functions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from models._types import IDENTITY, Array, Pose6, Vec3
from models.errors import InvalidInput
from models.hexapod import LEG_FIELDS, N_LEGS, HexapodGeometry
from models.robot import HEXAPOD_STAGE, RobotDescription
from models.serial_chain import Convention, DHLink, JointType, is_nearly_parallel
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, quaternion_to_matrix, rotvec_to_matrix_np

Document = dict[str, Any]

MAX_LINKS = 64
"""More links than any real robot; a bound on what one request can make the service build."""
QUATERNION_NORM_TOLERANCE = 1e-3
COLLINEAR_TOLERANCE_MM = 1e-6
"""Hexapod joints whose second singular value (centred, mm) is below this lie on one line."""
DEFAULT_MAX_CONDITION = 100.0
"""A hexapod pose whose length-scaled Jacobian is worse conditioned is near singular (the IWR's value)."""
WORKSPACE_AXES = ("x", "y", "z", "rz", "ry", "rx")
"""The workspace box's keys in the order of the platform pose `[x, y, z, α (about z), β (y), γ (x)]`."""

_DEG = math.pi / 180.0
_TOP_KEYS = {"base", "tool", "stages"}
_SERIAL_KEYS = {"kind", "convention", "links"}
_LINK_KEYS = {"joint", "a", "alpha", "d", "theta", "beta", "range"}
_HEXAPOD_KEYS = {"kind", "base_joints", "platform_joints", "strokes", "home", "workspace"}


# ---------------------------------------------------------------------------------------------- reading
def description_from_document(document: object, *, name: str = "custom") -> RobotDescription:
    """The validated description of a robots.md document (see the module docstring)."""
    doc = _mapping(document, "structure", _TOP_KEYS)
    stages = doc.get("stages")
    if not isinstance(stages, list) or not stages:
        raise InvalidInput("a structure needs a non-empty list of stages", field="stages")
    links: list[DHLink] = []
    layout: list[int] = []
    hexapod: HexapodGeometry | None = None
    for i, stage in enumerate(stages):
        where = f"stages[{i}]"
        kind = stage.get("kind") if isinstance(stage, Mapping) else None
        if kind == "serial":
            stage_links = _serial(stage, where)
            if len(links) + len(stage_links) > MAX_LINKS:
                raise InvalidInput(f"a structure has at most {MAX_LINKS} links", field=f"{where}.links")
            links += stage_links
            layout.append(len(stage_links))
        elif kind == "hexapod":
            if hexapod is not None:
                raise InvalidInput("a structure has at most one hexapod stage", field=f"{where}.kind")
            hexapod = _hexapod(stage, where)
            layout.append(HEXAPOD_STAGE)
        else:
            if not isinstance(stage, Mapping):
                raise InvalidInput("a stage must be an object", field=where)
            raise InvalidInput(
                f"unknown stage kind {kind!r}", field=f"{where}.kind", value=str(kind), allowed=["serial", "hexapod"]
            )
    if hexapod is None and not any(link.joint.moves for link in links):
        raise InvalidInput("a structure needs at least one moving joint (or a hexapod stage)", field="stages")
    base = _pose(doc["base"], "base") if doc.get("base") is not None else IDENTITY
    tool = _pose(doc["tool"], "tool") if doc.get("tool") is not None else IDENTITY
    return RobotDescription(name=name, links=tuple(links), hexapod=hexapod, base=base, tool=tool, stages=tuple(layout))


def _mapping(value: object, where: str, allowed: set[str]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise InvalidInput("must be an object", field=where)
    unknown = sorted(set(value) - allowed)
    if unknown:
        raise InvalidInput(
            f"unknown key {unknown[0]!r}", field=f"{where}.{unknown[0]}", value=str(unknown[0]), allowed=sorted(allowed)
        )
    return value


def _number(value: object, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(float(value)):
        raise InvalidInput(f"must be a finite number, got {value!r}", field=where, value=str(value))
    return float(value)


def _numbers(value: object, n: int, where: str) -> list[float]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != n:
        raise InvalidInput(f"must be a list of {n} numbers", field=where)
    return [_number(v, f"{where}[{k}]") for k, v in enumerate(value)]


def _interval(value: object, where: str) -> tuple[float, float]:
    lo, hi = _numbers(value, 2, where)
    if not lo < hi:
        raise InvalidInput(f"range [{lo:g}, {hi:g}] needs lo < hi", field=where, min=lo, max=hi)
    return lo, hi


def _serial(stage: Mapping[str, Any], where: str) -> list[DHLink]:
    _mapping(stage, where, _SERIAL_KEYS)
    convention = stage.get("convention")
    if convention not in ("dh", "mdh"):
        raise InvalidInput(
            f"unknown convention {convention!r}",
            field=f"{where}.convention",
            value=str(convention),
            allowed=["dh", "mdh"],
        )
    raw = stage.get("links")
    if not isinstance(raw, list) or not raw:
        raise InvalidInput("a serial stage needs a non-empty list of links", field=f"{where}.links")
    return [_link(link, Convention(convention), f"{where}.links[{k}]") for k, link in enumerate(raw)]


def _link(link: object, convention: Convention, where: str) -> DHLink:
    raw = _mapping(link, where, _LINK_KEYS)
    joint = raw.get("joint")
    if joint not in ("revolute", "prismatic", "fixed"):
        raise InvalidInput(
            f"unknown joint type {joint!r}",
            field=f"{where}.joint",
            value=str(joint),
            allowed=["revolute", "prismatic", "fixed"],
        )
    kind = JointType(joint)
    values = {k: _number(raw.get(k, 0.0), f"{where}.{k}") for k in ("a", "alpha", "d", "theta")}
    alpha = values["alpha"] * _DEG
    beta = 0.0
    if "beta" in raw:
        # robots.md gives mdh links with parallel axes their beta; dh links with parallel axes may carry one too
        # (an addition, README "Any robot"), which puts them in Hayati's form.
        if not is_nearly_parallel(alpha):
            raise InvalidInput(
                "beta belongs only to links whose axis is parallel to the next (dh) or previous (mdh) one "
                "(alpha 0 or ±180°, within 5° for a calibrated twist)",
                field=f"{where}.beta",
            )
        beta = _number(raw["beta"], f"{where}.beta") * _DEG
    if kind is JointType.FIXED:
        if raw.get("range") is not None:
            raise InvalidInput("a fixed link has no joint, so no range", field=f"{where}.range")
        lo, hi = 0.0, 0.0
    else:
        if "range" not in raw:
            raise InvalidInput("a moving joint needs its range [lo, hi]", field=f"{where}.range")
        lo, hi = _interval(raw["range"], f"{where}.range")
        if kind is JointType.REVOLUTE:
            lo, hi = lo * _DEG, hi * _DEG
    return DHLink(
        kind,
        theta=values["theta"] * _DEG,
        d=values["d"],
        a=values["a"],
        alpha=alpha,
        joint_min=lo,
        joint_max=hi,
        convention=convention,
        beta=beta,
        beta_given="beta" in raw,
    )


def _points(value: object, where: str) -> tuple[Vec3, ...]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != N_LEGS:
        raise InvalidInput(f"must be {N_LEGS} points [x, y, z]", field=where)
    pts = [_numbers(p, 3, f"{where}[{k}]") for k, p in enumerate(value)]
    arr = np.array(pts)
    # Six joints on one line (or one point) leave the platform free to turn about it: no hexapod.
    s = np.linalg.svd(arr - arr.mean(axis=0), compute_uv=False)
    if s[1] < COLLINEAR_TOLERANCE_MM:
        raise InvalidInput("the six joints are collinear", field=where, reason="collinear")
    return tuple((p[0], p[1], p[2]) for p in pts)


def _quaternion(value: object, where: str) -> Array:
    q = np.array(_numbers(value, 4, where))
    norm = float(np.linalg.norm(q))
    if abs(norm - 1.0) > QUATERNION_NORM_TOLERANCE:
        raise InvalidInput(f"must be a unit quaternion [w, x, y, z], norm {norm:.6g}", field=where, value=norm)
    return q / norm


def _pose(value: object, where: str) -> Pose6:
    raw = _mapping(value, where, {"position", "orientation"})
    p = _numbers(raw.get("position"), 3, f"{where}.position")
    rv = matrix_to_rotvec_np(quaternion_to_matrix(_quaternion(raw.get("orientation"), f"{where}.orientation")))
    return (p[0], p[1], p[2], float(rv[0]), float(rv[1]), float(rv[2]))


def euler_zyx_of(r: Array) -> tuple[float, float, float]:
    """(α, β, γ) with R = Rz(α) Ry(β) Rx(γ), β in [-90°, 90°]."""
    beta = float(np.arcsin(np.clip(-r[2, 0], -1.0, 1.0)))
    return float(np.arctan2(r[1, 0], r[0, 0])), beta, float(np.arctan2(r[2, 1], r[2, 2]))


def euler_zyx_matrix(alpha: float, beta: float, gamma: float) -> Array:
    ca_, sa = math.cos(alpha), math.sin(alpha)
    cb, sb = math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    rz = np.array([[ca_, -sa, 0], [sa, ca_, 0], [0, 0, 1]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rx = np.array([[1, 0, 0], [0, cg, -sg], [0, sg, cg]])
    return np.asarray(rz @ ry @ rx, dtype=float)


def _hexapod(stage: Mapping[str, Any], where: str) -> HexapodGeometry:
    _mapping(stage, where, _HEXAPOD_KEYS)
    a = _points(stage.get("base_joints"), f"{where}.base_joints")
    b = _points(stage.get("platform_joints"), f"{where}.platform_joints")
    strokes = stage.get("strokes")
    if isinstance(strokes, Sequence) and len(strokes) == N_LEGS:
        pairs = [_interval(s, f"{where}.strokes[{k}]") for k, s in enumerate(strokes)]
        s_min: float | tuple[float, ...] = tuple(p[0] for p in pairs)
        s_max: float | tuple[float, ...] = tuple(p[1] for p in pairs)
    else:
        s_min, s_max = _interval(strokes, f"{where}.strokes")
    home_raw = _mapping(stage.get("home"), f"{where}.home", {"position", "orientation"})
    p = _numbers(home_raw.get("position"), 3, f"{where}.home.position")
    rot = quaternion_to_matrix(_quaternion(home_raw.get("orientation"), f"{where}.home.orientation"))
    al, be, ga = euler_zyx_of(rot)
    home: Pose6 = (p[0], p[1], p[2], al, be, ga)
    if stage.get("workspace") is not None:
        ws = _mapping(stage["workspace"], f"{where}.workspace", set(WORKSPACE_AXES))
        box = []
        for k, axis in enumerate(WORKSPACE_AXES):
            if axis not in ws:
                raise InvalidInput(f"the workspace needs {axis!r}", field=f"{where}.workspace.{axis}")
            lo, hi = _interval(ws[axis], f"{where}.workspace.{axis}")
            box.append((lo, hi) if k < 3 else (lo * _DEG, hi * _DEG))
        lo6 = tuple(v[0] for v in box)
        hi6 = tuple(v[1] for v in box)
    else:
        # No workspace given: a box around home, a tenth of the platform's size and ±5°, for sampling.
        reach = 0.1 * max(float(np.linalg.norm(np.array(b), axis=1).max()), 1.0)
        lo6 = tuple(h - (reach if k < 3 else 5 * _DEG) for k, h in enumerate(home))
        hi6 = tuple(h + (reach if k < 3 else 5 * _DEG) for k, h in enumerate(home))
    if not all(lo <= h <= hi for lo, h, hi in zip(lo6, home, hi6, strict=True)):
        raise InvalidInput(
            "the home pose lies outside the workspace", field=f"{where}.home", reason="outside_workspace"
        )
    legs = np.linalg.norm(np.array(p)[None, :] + (rot @ np.array(b).T).T - np.array(a), axis=1)
    mins, maxs = np.broadcast_to(s_min, N_LEGS), np.broadcast_to(s_max, N_LEGS)
    bad = np.flatnonzero((legs < mins) | (legs > maxs))
    if bad.size:
        k = int(bad[0])
        raise InvalidInput(
            f"at home, leg {k + 1} is {legs[k]:.6g} mm long, beyond its stroke [{mins[k]:g}, {maxs[k]:g}] mm",
            field=f"{where}.home",
            reason="beyond_strokes",
            value=float(legs[k]),
            min=float(mins[k]),
            max=float(maxs[k]),
        )
    return HexapodGeometry(
        base_joints=a,
        platform_joints=b,
        leg_offsets=(0.0,) * N_LEGS,
        stroke_min=s_min,
        stroke_max=s_max,
        home=home,
        workspace_min=(lo6[0], lo6[1], lo6[2], lo6[3], lo6[4], lo6[5]),
        workspace_max=(hi6[0], hi6[1], hi6[2], hi6[3], hi6[4], hi6[5]),
        max_condition=DEFAULT_MAX_CONDITION,
    )


# ---------------------------------------------------------------------------------------------- writing
def description_document(desc: RobotDescription, params: Array | None = None) -> Document:
    """The robots.md document of `desc`, with the values of `params` (internal units; default nominal).

    Leg offsets have no place in the document: a calibrated offset `δl_i` is folded into nothing and is
    returned by the parameters endpoint instead (the document describes geometry, not encoder offsets).
    """
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    index = desc.parameters.index
    stages: list[dict[str, Any]] = []
    at = 0
    for size in desc.stage_layout:
        if size == HEXAPOD_STAGE:
            stages.append(_hexapod_document(desc, theta))
            continue
        links = []
        for k in range(at, at + size):
            link = desc.links[k]
            row: dict[str, Any] = {"joint": link.joint.value}
            for f in link.fields:
                value = float(theta[index[f"link{k + 1}.{f}"]])
                row[f] = value if f in ("a", "d") else math.degrees(value)
            if link.joint.moves:
                scale = 1.0 if link.joint is JointType.PRISMATIC else math.degrees(1.0)
                row["range"] = [link.joint_min * scale, link.joint_max * scale]
            links.append(row)
        conventions = {link.convention for link in desc.links[at : at + size]}
        stages.append({"kind": "serial", "convention": conventions.pop().value, "links": links})
        at += size
    return {
        "base": _pose_document(theta[desc.slices["base"]]),
        "tool": _pose_document(theta[desc.slices["tool"]]),
        "stages": stages,
    }


def _pose_document(pose6: Array) -> dict[str, list[float]]:
    quat = matrix_to_quaternion(rotvec_to_matrix_np(pose6[3:6]))
    return {"position": [float(v) for v in pose6[:3]], "orientation": [float(v) for v in quat]}


def _hexapod_document(desc: RobotDescription, theta: Array) -> dict[str, Any]:
    hexapod = desc.hexapod
    assert hexapod is not None
    per_leg = theta[desc.slices["legs"]].reshape(N_LEGS, len(LEG_FIELDS))
    home = np.asarray(hexapod.home)
    mins, maxs = hexapod.stroke_mins, hexapod.stroke_maxs
    strokes: list[Any] = (
        [mins[0], maxs[0]]
        if len(set(mins)) == 1 and len(set(maxs)) == 1
        else [[lo, hi] for lo, hi in zip(mins, maxs, strict=True)]
    )
    workspace = {
        axis: [
            hexapod.workspace_min[k] * (1.0 if k < 3 else math.degrees(1.0)),
            hexapod.workspace_max[k] * (1.0 if k < 3 else math.degrees(1.0)),
        ]
        for k, axis in enumerate(WORKSPACE_AXES)
    }
    home_quat = matrix_to_quaternion(euler_zyx_matrix(home[3], home[4], home[5]))
    return {
        "kind": "hexapod",
        "base_joints": [[float(v) for v in leg[0:3]] for leg in per_leg],
        "platform_joints": [[float(v) for v in leg[3:6]] for leg in per_leg],
        "strokes": strokes,
        "home": {"position": [float(v) for v in home[:3]], "orientation": [float(v) for v in home_quat]},
        "workspace": workspace,
    }
