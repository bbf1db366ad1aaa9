"""A robot description: base transform · DH chain · hexapod · tool.

A `RobotDescription` is a frozen, hashable value: everything needed to build
the robot's CasADi functions. The IWR is one instance (`models.iwr`); another
carriage or hexapod is another description, not new code.

Parameter vector layout (spec order): base (6), chain (4 per link), hexapod
(7 per leg), tool (6). Base and tool are a translation (mm) and a rotation
vector (rad).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from models._types import IDENTITY, Pose6
from models.hexapod import N_LEGS, PARAMS_PER_LEG, HexapodGeometry, hexapod_parameter_specs, platform_rotation
from models.parameters import Kind, ParameterScales, ParameterSpec, ParameterTable
from models.serial_chain import DHLink, JointType, chain_transform, dh_parameter_specs
from models.transforms import Sym, homogeneous, rotvec_to_matrix

Structure = tuple[JointType, ...]
"""What the CasADi graphs depend on: the joint type of each chain link (the hexapod always has six legs)."""


@dataclass(frozen=True)
class RobotDescription:
    name: str
    links: tuple[DHLink, ...]
    hexapod: HexapodGeometry
    base: Pose6 = IDENTITY
    """World <- {0}: x, y, z (mm), rotation vector (rad)."""
    tool: Pose6 = IDENTITY
    """{platform} -> TCP: x, y, z (mm), rotation vector (rad)."""
    scales: ParameterScales = field(default_factory=ParameterScales)
    """Expected error per parameter kind: the column scaling of identification and design."""

    @cached_property
    def structure(self) -> Structure:
        """The key of everything built from this description (`models.runtime`): geometry, base and tool are
        inputs of the graphs, so every description with these joint types shares one runtime."""
        return tuple(link.joint for link in self.links)

    # ------------------------------------------------------------ joints
    @property
    def n_chain(self) -> int:
        return len(self.links)

    @property
    def n_joints(self) -> int:
        return self.n_chain + N_LEGS

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(f"q{i + 1}" for i in range(self.n_chain)) + tuple(f"l{i + 1}" for i in range(N_LEGS))

    @cached_property
    def joint_kinds(self) -> tuple[Kind, ...]:
        return tuple(link.joint.kind for link in self.links) + (Kind.LENGTH,) * N_LEGS

    @cached_property
    def joint_min(self) -> NDArray[np.float64]:
        legs = [self.hexapod.stroke_min] * N_LEGS
        return np.array([link.joint_min for link in self.links] + legs)

    @cached_property
    def joint_max(self) -> NDArray[np.float64]:
        legs = [self.hexapod.stroke_max] * N_LEGS
        return np.array([link.joint_max for link in self.links] + legs)

    @cached_property
    def joint_to_boundary(self) -> NDArray[np.float64]:
        """Factor from internal joint units (mm, rad) to boundary units (mm, deg)."""
        return np.array([k.to_boundary for k in self.joint_kinds])

    # -------------------------------------------------------- parameters
    @cached_property
    def parameters(self) -> ParameterTable:
        tol = self.scales
        specs: list[ParameterSpec] = []
        specs += _pose_specs("base", self.base, tol.base_length, tol.base_angle)
        specs += dh_parameter_specs(self.links, tol.dh_length, tol.dh_angle)
        specs += hexapod_parameter_specs(self.hexapod, tol.hexapod_joint, tol.leg_offset)
        specs += _pose_specs("tool", self.tool, tol.tool_length, tol.tool_angle)
        return ParameterTable(tuple(specs))

    @property
    def n_params(self) -> int:
        return len(self.parameters)

    @cached_property
    def slices(self) -> dict[str, slice]:
        n_dh = 4 * self.n_chain
        n_hex = PARAMS_PER_LEG * N_LEGS
        return {
            "base": slice(0, 6),
            "carriage": slice(6, 6 + n_dh),
            "hexapod": slice(6 + n_dh, 6 + n_dh + n_hex),
            "tool": slice(6 + n_dh + n_hex, 12 + n_dh + n_hex),
        }

    def with_base_tool(self, base: Pose6 | None = None, tool: Pose6 | None = None) -> RobotDescription:
        return replace(self, base=base if base is not None else self.base, tool=tool if tool is not None else self.tool)


def _pose_specs(prefix: str, pose: Pose6, length_scale: float, angle_scale: float) -> list[ParameterSpec]:
    names = ("x", "y", "z", "rx", "ry", "rz")
    return [
        ParameterSpec(
            name=f"{prefix}.{n}",
            group=prefix,
            kind=Kind.LENGTH if k < 3 else Kind.ANGLE,
            nominal=float(pose[k]),
            scale=length_scale if k < 3 else angle_scale,
        )
        for k, n in enumerate(names)
    ]


def pose_transform(pose6: Sym) -> Sym:
    """4x4 transform of a (translation, rotation vector) 6-vector."""
    return homogeneous(rotvec_to_matrix(pose6[3:6]), pose6[0:3])


def carriage_transform(desc: RobotDescription, q_chain: Sym, params: Sym) -> Sym:
    """World <- {n}: base · chain."""
    s = desc.slices
    return pose_transform(params[s["base"]]) @ chain_transform(desc.links, q_chain, params[s["carriage"]])


def tcp_transform(desc: RobotDescription, q_chain: Sym, platform: Sym, params: Sym) -> Sym:
    """World <- TCP for chain joints and a platform pose (p, Z-Y-X Euler) of the hexapod."""
    s = desc.slices
    hexapod = homogeneous(platform_rotation(platform), platform[0:3])
    return carriage_transform(desc, q_chain, params) @ hexapod @ pose_transform(params[s["tool"]])
