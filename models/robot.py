"""A robot description: base transform · serial links and at most one hexapod, in any order · tool.

A `RobotDescription` is a frozen, hashable value: everything needed to build
the robot's CasADi functions. The IWR is one instance (`models.iwr`); another
carriage or hexapod is another description, not new code.

Parameter vector layout (spec order, `shared/spec/robots.md`): base (6), links
(4 per link, 5 with Hayati's beta), hexapod (7 per leg, if any), tool (6). Base
and tool are a translation (mm) and a rotation vector (rad).
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from models._types import IDENTITY, Pose6
from models.errors import InvalidInput
from models.hexapod import N_LEGS, PARAMS_PER_LEG, HexapodGeometry, hexapod_parameter_specs, platform_rotation
from models.parameters import Kind, ParameterScales, ParameterSpec, ParameterTable
from models.serial_chain import Convention, DHLink, JointType, chain_transform, dh_parameter_specs
from models.terms import ModelTerms
from models.transforms import Sym, homogeneous, rotvec_to_matrix

Structure = tuple[Hashable, ...]
"""What the CasADi graphs depend on: per link its convention, joint type and whether it has Hayati's `beta`,
and where the hexapod stage sits (the number of links before it, or None without one). Geometry, base and
tool are inputs of the graphs, never part of the key. No user string is in it."""

HEXAPOD_STAGE = 0
"""In `RobotDescription.stages`, a hexapod stage; a positive number is a serial stage of that many links."""


@dataclass(frozen=True)
class RobotDescription:
    """A chain of stages (`shared/spec/robots.md`): serial links (all serial stages' links in order), at most
    one hexapod, base and tool. `stages` keeps the document's stage boundaries: a serial stage is its number
    of links, the hexapod `HEXAPOD_STAGE`; by default the links followed by the hexapod (the IWR's shape)."""

    name: str
    links: tuple[DHLink, ...]
    hexapod: HexapodGeometry | None
    base: Pose6 = IDENTITY
    """World <- {0}: x, y, z (mm), rotation vector (rad)."""
    tool: Pose6 = IDENTITY
    """{last frame} -> TCP: x, y, z (mm), rotation vector (rad)."""
    scales: ParameterScales = field(default_factory=ParameterScales)
    """Expected error per parameter kind: the column scaling of identification and design."""
    stages: tuple[int, ...] | None = None
    terms: ModelTerms = field(default_factory=ModelTerms)
    """Model terms beyond geometry (`models.terms`): off by default."""

    @cached_property
    def stage_layout(self) -> tuple[int, ...]:
        if self.stages is not None:
            return self.stages
        serial = (len(self.links),) if self.links else ()
        return serial + ((HEXAPOD_STAGE,) if self.hexapod is not None else ())

    @cached_property
    def hexapod_at(self) -> int | None:
        """How many links come before the hexapod stage (None: no hexapod)."""
        if self.hexapod is None:
            return None
        before = 0
        for size in self.stage_layout:
            if size == HEXAPOD_STAGE:
                return before
            before += size
        return before

    @cached_property
    def structure(self) -> Structure:
        """The key of everything built from this description (`models.runtime`): geometry, base and tool are
        inputs of the graphs, so every description with this structure shares one runtime. The model terms
        switched on change the graphs, so they are part of the key; without terms the key is the geometric one."""
        geometric = self.geometric_structure
        if not self.terms.any:
            return geometric
        return ("terms", self.terms.thermal, self.terms.compliance, geometric)

    @cached_property
    def geometric_structure(self) -> Structure:
        if self.hexapod is not None and self.hexapod_at == len(self.links) and self.is_classic:
            # The IWR's shape keeps its key of joint types alone.
            return tuple(link.joint for link in self.links)
        return (tuple(link.token for link in self.links), self.hexapod_at)

    @cached_property
    def geometric(self) -> RobotDescription:
        """This robot without model terms (itself when it has none)."""
        return replace(self, terms=ModelTerms()) if self.terms.any else self

    @cached_property
    def revolute_joints(self) -> tuple[int, ...]:
        """Indices (among the serial joints) of the revolute ones."""
        return tuple(k for k, link in enumerate(self.moving_links) if link.joint is JointType.REVOLUTE)

    @property
    def has_prismatic(self) -> bool:
        return any(link.joint is JointType.PRISMATIC for link in self.links)

    def with_terms(self, terms: ModelTerms) -> RobotDescription:
        """This robot with `terms`; InvalidInput (field `terms`) when a term has nothing to act on."""
        if terms.thermal and self.hexapod is None and not self.has_prismatic:
            raise InvalidInput(
                "the thermal term acts on hexapod legs and prismatic axes; this robot has neither",
                field="terms",
                value="thermal",
            )
        if terms.compliance and self.hexapod is None and not self.revolute_joints:
            raise InvalidInput(
                "the compliance term acts on hexapod legs or revolute joints; this robot has neither",
                field="terms",
                value="compliance",
            )
        terms.gravity_unit()  # validated now, not at the first evaluation
        return replace(self, terms=terms)

    @property
    def is_classic(self) -> bool:
        """Standard-DH moving links followed by a hexapod: the IWR's shape, whose parameter groups keep the
        IWR's names (`carriage`, `hexapod`)."""
        return self.hexapod is not None and all(
            link.convention is Convention.DH and link.joint.moves for link in self.links
        )

    @property
    def has_hexapod(self) -> bool:
        return self.hexapod is not None

    @property
    def n_ik(self) -> int:
        """Unknowns of the inverse kinematics: the serial joints, and the platform pose (6) of a hexapod."""
        return self.n_chain + (6 if self.hexapod is not None else 0)

    # ------------------------------------------------------------ joints
    @cached_property
    def n_chain(self) -> int:
        """Serial joints (fixed links have none)."""
        return sum(link.joint.moves for link in self.links)

    @property
    def n_legs(self) -> int:
        return N_LEGS if self.hexapod is not None else 0

    @property
    def n_joints(self) -> int:
        return self.n_chain + self.n_legs

    @cached_property
    def moving_links(self) -> tuple[DHLink, ...]:
        return tuple(link for link in self.links if link.joint.moves)

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(f"q{i + 1}" for i in range(self.n_chain)) + tuple(f"l{i + 1}" for i in range(self.n_legs))

    @cached_property
    def joint_kinds(self) -> tuple[Kind, ...]:
        return tuple(link.joint.kind for link in self.moving_links) + (Kind.LENGTH,) * self.n_legs

    @cached_property
    def joint_min(self) -> NDArray[np.float64]:
        legs = [] if self.hexapod is None else list(self.hexapod.stroke_mins)
        return np.array([link.joint_min for link in self.moving_links] + legs, dtype=float)

    @cached_property
    def joint_max(self) -> NDArray[np.float64]:
        legs = [] if self.hexapod is None else list(self.hexapod.stroke_maxs)
        return np.array([link.joint_max for link in self.moving_links] + legs, dtype=float)

    @cached_property
    def joint_to_boundary(self) -> NDArray[np.float64]:
        """Factor from internal joint units (mm, rad) to boundary units (mm, deg)."""
        return np.array([k.to_boundary for k in self.joint_kinds])

    @property
    def platform_home(self) -> Pose6:
        """The hexapod's home pose, the first guess of its forward kinematics (zeros without a hexapod: the
        platform variable of the graphs is then unused and solved in one step)."""
        return self.hexapod.home if self.hexapod is not None else IDENTITY

    # -------------------------------------------------------- parameters
    @property
    def link_group(self) -> str:
        return "carriage" if self.is_classic else "links"

    @property
    def leg_group(self) -> str:
        return "hexapod" if self.is_classic else "legs"

    @cached_property
    def parameters(self) -> ParameterTable:
        tol = self.scales
        specs: list[ParameterSpec] = []
        specs += _pose_specs("base", self.base, tol.base_length, tol.base_angle)
        specs += dh_parameter_specs(self.links, tol.dh_length, tol.dh_angle, self.link_group)
        if self.hexapod is not None:
            specs += hexapod_parameter_specs(self.hexapod, tol.hexapod_joint, tol.leg_offset, self.leg_group)
        specs += _pose_specs("tool", self.tool, tol.tool_length, tol.tool_angle)
        specs += self._term_specs()
        return ParameterTable(tuple(specs))

    def _term_specs(self) -> list[ParameterSpec]:
        """The terms' parameters, after the tool (so every geometric slice stays where it was)."""
        terms, tol, out = self.terms, self.scales, []
        if terms.thermal and self.hexapod is not None:
            out.append(ParameterSpec("thermal.legs", "thermal", Kind.THERMAL, terms.kappa_legs, tol.thermal))
        if terms.thermal and self.has_prismatic:
            out.append(ParameterSpec("thermal.axes", "thermal", Kind.THERMAL, terms.kappa_axes, tol.thermal))
        if terms.compliance and self.hexapod is not None:
            out += [
                ParameterSpec(
                    f"compliance.leg{i + 1}", "compliance", Kind.COMPLIANCE, terms.leg_compliance, tol.compliance
                )
                for i in range(N_LEGS)
            ]
        if terms.compliance and self.hexapod is None:  # a serial robot: its revolute joints
            out += [
                ParameterSpec(
                    f"compliance.joint{k + 1}",
                    "compliance",
                    Kind.JOINT_COMPLIANCE,
                    terms.joint_compliance,
                    tol.joint_compliance,
                )
                for k in self.revolute_joints
            ]
        return out

    @cached_property
    def term_index(self) -> dict[str, int]:
        """Index of each term parameter present (`thermal.legs`, `thermal.axes`, `compliance.leg1`...)."""
        n_geo = self.slices["tool"].stop
        return {spec.name: n_geo + k for k, spec in enumerate(self._term_specs())}

    @property
    def n_params(self) -> int:
        return len(self.parameters)

    @cached_property
    def slices(self) -> dict[str, slice]:
        """Parameter slices by group; `carriage`/`links` and `hexapod`/`legs` name the same slices."""
        n_dh = sum(link.n_params for link in self.links)
        n_hex = PARAMS_PER_LEG * self.n_legs
        links = slice(6, 6 + n_dh)
        legs = slice(6 + n_dh, 6 + n_dh + n_hex)
        return {
            "base": slice(0, 6),
            "carriage": links,
            "links": links,
            "hexapod": legs,
            "legs": legs,
            "tool": slice(6 + n_dh + n_hex, 12 + n_dh + n_hex),
            "terms": slice(12 + n_dh + n_hex, 12 + n_dh + n_hex + len(self._term_specs())),
        }

    @cached_property
    def link_param_offsets(self) -> tuple[int, ...]:
        """Start of each link's parameters inside the links' slice (and the total at the end)."""
        out = [0]
        for link in self.links:
            out.append(out[-1] + link.n_params)
        return tuple(out)

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


def links_transform(desc: RobotDescription, first: int, stop: int, q_chain: Sym, params: Sym) -> Sym:
    """{first} -> {stop}: links first..stop-1 (0-based) with their joints and parameters."""
    links = desc.links[first:stop]
    q0 = sum(link.joint.moves for link in desc.links[:first])
    n_q = sum(link.joint.moves for link in links)
    s = desc.slices["carriage"]
    p0, p1 = desc.link_param_offsets[first], desc.link_param_offsets[stop]
    return chain_transform(links, q_chain[q0 : q0 + n_q], params[s.start + p0 : s.start + p1])


def carriage_transform(desc: RobotDescription, q_chain: Sym, params: Sym) -> Sym:
    """World <- the hexapod's base frame (without a hexapod: world <- the last link's frame)."""
    s = desc.slices
    at = len(desc.links) if desc.hexapod_at is None else desc.hexapod_at
    if at == len(desc.links):
        return pose_transform(params[s["base"]]) @ chain_transform(desc.links, q_chain, params[s["carriage"]])
    return pose_transform(params[s["base"]]) @ links_transform(desc, 0, at, q_chain, params)


def tcp_transform(desc: RobotDescription, q_chain: Sym, platform: Sym, params: Sym) -> Sym:
    """World <- TCP for serial joints and a platform pose (p, Z-Y-X Euler) of the hexapod (ignored without one)."""
    s = desc.slices
    if desc.hexapod is None:
        return carriage_transform(desc, q_chain, params) @ pose_transform(params[s["tool"]])
    hexapod = homogeneous(platform_rotation(platform), platform[0:3])
    at = desc.hexapod_at if desc.hexapod_at is not None else len(desc.links)
    t = carriage_transform(desc, q_chain, params) @ hexapod
    if at < len(desc.links):
        t = t @ links_transform(desc, at, len(desc.links), q_chain, params)
    return t @ pose_transform(params[s["tool"]])
