"""A hexapod stage: a Stewart–Gough platform on six legs (robots.md "Hexapod stage").

Its joints are the six commanded leg lengths, its unknowns the platform pose `[x, y, z, α, β, γ]` (mm, Z-Y-X
Euler angles in rad) of its end frame in its start frame, pinned by the six leg equations; its parameters the
legs' joints and offsets (`models.description.hexapod`).
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from models._types import Array, Pose6, Vec3
from models.description.hexapod import (
    LEG_FIELDS,
    N_LEGS,
    PARAMS_PER_LEG,
    HexapodGeometry,
    actuator_lengths,
    closure_residual,
    hexapod_parameter_specs,
    platform_rotation,
)
from models.description.parameters import Kind, ParameterScales, ParameterSpec
from models.description.serial_chain import DHLink
from models.errors import InvalidInput
from models.stages.base import Section
from models.stages.document import (
    DEG,
    euler_zyx_matrix,
    euler_zyx_of,
    interval,
    mapping,
    numbers,
    quaternion,
)
from models.transforms import Sym, homogeneous, matrix_to_quaternion, quaternion_to_matrix

COLLINEAR_TOLERANCE_MM = 1e-6
"""Hexapod joints whose second singular value (centred, mm) is below this lie on one line."""
DEFAULT_MAX_CONDITION = 100.0
"""A hexapod pose whose length-scaled Jacobian is worse conditioned is near singular (the IWR's value)."""
WORKSPACE_AXES = ("x", "y", "z", "rz", "ry", "rx")
"""The workspace box's keys in the order of the platform pose `[x, y, z, α (about z), β (y), γ (x)]`."""
_KEYS = {"kind", "base_joints", "platform_joints", "strokes", "home", "workspace"}


@dataclass(frozen=True)
class HexapodStage:
    geometry: HexapodGeometry

    kind: ClassVar[str] = "hexapod"
    section: ClassVar[Section] = Section.LEGS
    group: ClassVar[str] = "legs"
    classic_group: ClassVar[str] = "hexapod"

    @property
    def n_joints(self) -> int:
        return N_LEGS

    @property
    def n_unknowns(self) -> int:
        return 6

    @property
    def n_params(self) -> int:
        return PARAMS_PER_LEG * N_LEGS

    @property
    def n_items(self) -> int:
        return N_LEGS

    @property
    def token(self) -> Hashable:
        return self.kind

    @property
    def moves(self) -> bool:
        return True

    @property
    def dh_links(self) -> tuple[DHLink, ...]:
        return ()

    def joint_names(self, first: int) -> tuple[str, ...]:
        return tuple(f"l{first + k}" for k in range(N_LEGS))

    def joint_kinds(self) -> tuple[Kind, ...]:
        return (Kind.LENGTH,) * N_LEGS

    def joint_limits(self) -> tuple[Array, Array]:
        return np.array(self.geometry.stroke_mins), np.array(self.geometry.stroke_maxs)

    def parameter_specs(self, first: int, scales: ParameterScales, group: str) -> list[ParameterSpec]:
        return hexapod_parameter_specs(self.geometry, scales.hexapod_joint, scales.leg_offset, group, first)

    def transform(self, q: Sym, x: Sym, p: Sym) -> Sym:
        return homogeneous(platform_rotation(x), x[0:3])

    def closure(self, q: Sym, x: Sym, p: Sym) -> Sym | None:
        return closure_residual(x, q, p)

    def unknown_home(self) -> tuple[float, ...]:
        return tuple(self.geometry.home)

    def unknown_limits(self) -> tuple[Array, Array]:
        return np.array(self.geometry.workspace_min), np.array(self.geometry.workspace_max)

    def joint_expressions(self, x: Sym, p: Sym) -> Sym:
        return actuator_lengths(x, p)

    def joints_of_unknowns(self, x: Array, p: Array) -> Array:
        a, b, offsets = _split(p)
        return np.asarray(np.linalg.norm(_leg_vectors(x, a, b), axis=2) - offsets, dtype=float)

    def conditioning(self, x: Array, p: Array) -> Array:
        """(N,) the condition number of the thesis Jacobian (eq. 48), rotations scaled by the platform radius:
        unit-free, without bound near a singularity."""
        a, b, _ = _split(p)
        v = _leg_vectors(x, a, b)
        u = v / np.linalg.norm(v, axis=2, keepdims=True)
        s = np.einsum("nij,kj->nki", _rotations(x), b)
        blocks = np.concatenate([u, np.cross(s, u) / self.geometry.characteristic_length], axis=2)
        eig = np.linalg.eigvalsh(np.einsum("nki,nkj->nij", blocks, blocks))
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(eig[:, 0] > 0, np.sqrt(eig[:, -1] / eig[:, 0]), np.inf)

    @property
    def max_condition(self) -> float:
        return self.geometry.max_condition

    def usable(self, q: Array, x: Array, p: Array) -> Array:
        lo, hi = self.joint_limits()
        ok = np.all((q >= lo) & (q <= hi), axis=1)
        return np.asarray(ok & (self.conditioning(x, p) <= self.geometry.max_condition))

    def document(self, p: Array) -> dict[str, Any]:
        """Leg offsets have no place in the document: a calibrated offset `δl_i` is returned by the parameters
        endpoint instead (the document describes geometry, not encoder offsets)."""
        hexapod = self.geometry
        per_leg = p.reshape(N_LEGS, len(LEG_FIELDS))
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
            "kind": self.kind,
            "base_joints": [[float(v) for v in leg[0:3]] for leg in per_leg],
            "platform_joints": [[float(v) for v in leg[3:6]] for leg in per_leg],
            "strokes": strokes,
            "home": {"position": [float(v) for v in home[:3]], "orientation": [float(v) for v in home_quat]},
            "workspace": workspace,
        }


def _split(p: Array) -> tuple[Array, Array, Array]:
    """(a (6, 3), b (6, 3), offsets (6,)) of the stage's 42 parameters."""
    per_leg = np.asarray(p, dtype=float).reshape(N_LEGS, PARAMS_PER_LEG)
    return per_leg[:, 0:3], per_leg[:, 3:6], per_leg[:, 6]


def _rotations(x: Array) -> Array:
    """(N, 3, 3) R = Rz(α) Ry(β) Rx(γ) of platform poses (N, 6)."""
    ca_, sa = np.cos(x[:, 3]), np.sin(x[:, 3])
    cb, sb = np.cos(x[:, 4]), np.sin(x[:, 4])
    cg, sg = np.cos(x[:, 5]), np.sin(x[:, 5])
    return np.stack(
        [
            np.stack([ca_ * cb, ca_ * sb * sg - sa * cg, ca_ * sb * cg + sa * sg], axis=1),
            np.stack([sa * cb, sa * sb * sg + ca_ * cg, sa * sb * cg - ca_ * sg], axis=1),
            np.stack([-sb, cb * sg, cb * cg], axis=1),
        ],
        axis=1,
    )


def _leg_vectors(x: Array, a: Array, b: Array) -> Array:
    """(N, 6, 3) p + R b_i - a_i."""
    return np.asarray(x[:, None, 0:3] + np.einsum("nij,kj->nki", _rotations(x), b) - a[None, :, :], dtype=float)


def read_hexapod(raw: Mapping[str, Any], where: str) -> HexapodStage:
    """robots.md's hexapod stage (see `models.stages.base.StageReader`)."""
    mapping(raw, where, _KEYS)
    a = _points(raw.get("base_joints"), f"{where}.base_joints")
    b = _points(raw.get("platform_joints"), f"{where}.platform_joints")
    strokes = raw.get("strokes")
    if isinstance(strokes, Sequence) and len(strokes) == N_LEGS:
        pairs = [interval(s, f"{where}.strokes[{k}]") for k, s in enumerate(strokes)]
        s_min: float | tuple[float, ...] = tuple(p[0] for p in pairs)
        s_max: float | tuple[float, ...] = tuple(p[1] for p in pairs)
    else:
        s_min, s_max = interval(strokes, f"{where}.strokes")
    home_raw = mapping(raw.get("home"), f"{where}.home", {"position", "orientation"})
    p = numbers(home_raw.get("position"), 3, f"{where}.home.position")
    rot = quaternion_to_matrix(quaternion(home_raw.get("orientation"), f"{where}.home.orientation"))
    al, be, ga = euler_zyx_of(rot)
    home: Pose6 = (p[0], p[1], p[2], al, be, ga)
    lo6, hi6 = _workspace(raw.get("workspace"), home, b, where)
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
    return HexapodStage(
        HexapodGeometry(
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
    )


def _workspace(
    raw: object, home: Pose6, b: tuple[Vec3, ...], where: str
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The platform's box (lo, hi), internal units."""
    if raw is None:
        # No workspace given: a box around home, a tenth of the platform's size and ±5°, for sampling.
        reach = 0.1 * max(float(np.linalg.norm(np.array(b), axis=1).max()), 1.0)
        lo6 = tuple(h - (reach if k < 3 else 5 * DEG) for k, h in enumerate(home))
        hi6 = tuple(h + (reach if k < 3 else 5 * DEG) for k, h in enumerate(home))
        return lo6, hi6
    ws = mapping(raw, f"{where}.workspace", set(WORKSPACE_AXES))
    box = []
    for k, axis in enumerate(WORKSPACE_AXES):
        if axis not in ws:
            raise InvalidInput(f"the workspace needs {axis!r}", field=f"{where}.workspace.{axis}")
        lo, hi = interval(ws[axis], f"{where}.workspace.{axis}")
        box.append((lo, hi) if k < 3 else (lo * DEG, hi * DEG))
    return tuple(v[0] for v in box), tuple(v[1] for v in box)


def _points(value: object, where: str) -> tuple[Vec3, ...]:
    if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != N_LEGS:
        raise InvalidInput(f"must be {N_LEGS} points [x, y, z]", field=where)
    pts = [numbers(p, 3, f"{where}[{k}]") for k, p in enumerate(value)]
    arr = np.array(pts)
    # Six joints on one line (or one point) leave the platform free to turn about it: no hexapod.
    s = np.linalg.svd(arr - arr.mean(axis=0), compute_uv=False)
    if s[1] < COLLINEAR_TOLERANCE_MM:
        raise InvalidInput("the six joints are collinear", field=where, reason="collinear")
    return tuple((p[0], p[1], p[2]) for p in pts)
