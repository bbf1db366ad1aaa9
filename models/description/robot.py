"""A robot description: base transform · serial links and at most one hexapod, in any order · tool.

A `RobotDescription` is a frozen, hashable value: everything needed to build
the robot's CasADi functions. The IWR is one instance (`models.description.iwr`); another
carriage or hexapod is another description, not new code.

Parameter vector layout (spec order, `shared/spec/robots.md`): base (6), links
(4 per link, 5 with Hayati's beta), hexapod (7 per leg, if any), tool (6). Base
and tool are a translation (mm) and a rotation vector (rad).
"""

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass, field, replace
from functools import cached_property

import casadi as ca
import numpy as np
from numpy.typing import NDArray

from models._types import IDENTITY, Pose6
from models.description.hexapod import N_LEGS, HexapodGeometry
from models.description.parameters import Kind, ParameterScales, ParameterSpec, ParameterTable
from models.description.serial_chain import Convention, DHLink, JointType, chain_transform
from models.description.terms import ModelTerms
from models.errors import InvalidInput
from models.stages import HexapodStage, Placement, Section, SerialStage, Stage
from models.transforms import Sym, homogeneous, rotvec_to_matrix

Structure = tuple[Hashable, ...]
"""What the CasADi graphs depend on: per link its convention, joint type and whether it has Hayati's `beta`,
and where the hexapod stage sits (the number of links before it, or None without one); other chains of stages
are keyed by their stages' tokens. Geometry, base and tool are inputs of the graphs, never part of the key. No
user string is in it."""


@dataclass(frozen=True)
class RobotDescription:
    """A chain of stages (`shared/spec/robots.md`, `models.stages`) between a base and a tool.

    The stages are kept in the document's order (the order of their frames); their joints and parameters are
    laid out by section (every serial joint and link parameter before every leg), as robots.md orders them.
    """

    name: str
    stages: tuple[Stage, ...]
    base: Pose6 = IDENTITY
    """World <- {0}: x, y, z (mm), rotation vector (rad)."""
    tool: Pose6 = IDENTITY
    """{last frame} -> TCP: x, y, z (mm), rotation vector (rad)."""
    scales: ParameterScales = field(default_factory=ParameterScales)
    """Expected error per parameter kind: the column scaling of identification and design."""
    terms: ModelTerms = field(default_factory=ModelTerms)
    """Model terms beyond geometry (`models.description.terms`): off by default."""

    # ------------------------------------------------------------ stages
    @cached_property
    def placements(self) -> tuple[Placement, ...]:
        """Where each stage's joints, unknowns and parameters sit (`models.stages.Placement`), in stage order."""
        joint_at = {Section.LINKS: 0, Section.LEGS: sum(s.n_joints for s in self.stages if s.section < Section.LEGS)}
        n_links_params = sum(s.n_params for s in self.stages if s.section is Section.LINKS)
        param_at = {Section.LINKS: 6, Section.LEGS: 6 + n_links_params}
        number = {Section.LINKS: 1, Section.LEGS: 1}
        joint_number = {Section.LINKS: 1, Section.LEGS: 1}
        unknown_at = 0
        out = []
        for i, stage in enumerate(self.stages):
            sec = stage.section
            out.append(
                Placement(
                    index=i,
                    joints=slice(joint_at[sec], joint_at[sec] + stage.n_joints),
                    unknowns=slice(unknown_at, unknown_at + stage.n_unknowns),
                    params=slice(param_at[sec], param_at[sec] + stage.n_params),
                    first_item=number[sec],
                    first_joint=joint_number[sec],
                )
            )
            joint_at[sec] += stage.n_joints
            param_at[sec] += stage.n_params
            number[sec] += stage.n_items
            joint_number[sec] += stage.n_joints
            unknown_at += stage.n_unknowns
        return tuple(out)

    @cached_property
    def by_section(self) -> tuple[tuple[Stage, Placement], ...]:
        """The stages with their placements in the order of the robot's vectors (serial, then parallel)."""
        pairs = zip(self.stages, self.placements, strict=True)
        return tuple(sorted(pairs, key=lambda sp: (sp[0].section, sp[1].index)))

    @cached_property
    def links(self) -> tuple[DHLink, ...]:
        """Every DH/MDH link of the robot, in order (numbered 1, 2, … across its serial stages)."""
        return tuple(link for stage in self.stages for link in stage.dh_links)

    @cached_property
    def closed_stages(self) -> tuple[int, ...]:
        """Indices of the stages with unknowns pinned by closure equations (parallel stages)."""
        return tuple(i for i, stage in enumerate(self.stages) if stage.n_unknowns)

    @property
    def has_closure(self) -> bool:
        """Whether some joints act through closure equations (a parallel stage): forward kinematics is then a
        root, not a product."""
        return bool(self.closed_stages)

    @cached_property
    def n_unknowns(self) -> int:
        """The closures' unknowns: 6 per platform pose."""
        return sum(stage.n_unknowns for stage in self.stages)

    @property
    def n_platform(self) -> int:
        """Rows of the graphs' `platform` input: the closures' unknowns, or 6 pinned by g = x without any (one
        signature for every structure, see `models.engine.symbolic`)."""
        return self.n_unknowns or 6

    @cached_property
    def hexapod(self) -> HexapodGeometry | None:
        """The hexapod's geometry, for the hexapod-specific models (terms, the hexapod alone); None without one.
        Several parallel stages are composed by the symbolic model but have no such single geometry."""
        found = [stage.geometry for stage in self.stages if isinstance(stage, HexapodStage)]
        if len(found) > 1:
            raise InvalidInput(
                "this operation models a single hexapod; the robot has several parallel stages", field="stages"
            )
        return found[0] if found else None

    @cached_property
    def hexapod_at(self) -> int | None:
        """How many links come before the hexapod stage (None: no hexapod)."""
        before = 0
        for stage in self.stages:
            if isinstance(stage, HexapodStage):
                return before
            before += len(stage.dh_links)
        return None

    @cached_property
    def structure(self) -> Structure:
        """The key of everything built from this description (`models.engine.runtime`): geometry, base and tool are
        inputs of the graphs, so every description with this structure shares one runtime. The model terms
        switched on change the graphs, so they are part of the key; without terms the key is the geometric one."""
        geometric = self.geometric_structure
        if not self.terms.any:
            return geometric
        return ("terms", self.terms.thermal, self.terms.compliance, geometric)

    @cached_property
    def geometric_structure(self) -> Structure:
        parallel = sum(stage.n_unknowns > 0 for stage in self.stages)
        known = all(isinstance(stage, SerialStage | HexapodStage) for stage in self.stages)
        if parallel > 1 or not known:
            return ("stages", tuple((stage.kind, stage.token) for stage in self.stages))
        if self.hexapod_at == len(self.links) and self.is_classic:
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
        if terms.any and len(self.closed_stages) > 1:
            raise InvalidInput(
                "the thermal and compliance terms model one hexapod; this robot has several parallel stages",
                field="terms",
            )
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
        """Standard-DH moving links and one hexapod: the IWR's shape, whose parameter groups keep the IWR's
        names (`carriage`, `hexapod`)."""
        return (
            len(self.closed_stages) == 1
            and self.hexapod_at is not None
            and all(link.convention is Convention.DH and link.joint.moves for link in self.links)
        )

    @property
    def n_ik(self) -> int:
        """Unknowns of the inverse kinematics: the serial joints, and the closures' unknowns (platform poses)."""
        return self.n_chain + self.n_unknowns

    # ------------------------------------------------------------ joints
    @cached_property
    def n_chain(self) -> int:
        """Serial joints (fixed links have none): the joints before the legs."""
        return sum(stage.n_joints for stage in self.stages if stage.section is Section.LINKS)

    @property
    def n_legs(self) -> int:
        return self.n_joints - self.n_chain

    @cached_property
    def n_joints(self) -> int:
        return sum(stage.n_joints for stage in self.stages)

    @cached_property
    def moving_links(self) -> tuple[DHLink, ...]:
        return tuple(link for link in self.links if link.joint.moves)

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(name for stage, at in self.by_section for name in stage.joint_names(at.first_joint))

    @cached_property
    def joint_kinds(self) -> tuple[Kind, ...]:
        return tuple(kind for stage, _ in self.by_section for kind in stage.joint_kinds())

    @cached_property
    def joint_min(self) -> NDArray[np.float64]:
        return np.concatenate([stage.joint_limits()[0] for stage, _ in self.by_section]).astype(float)

    @cached_property
    def joint_max(self) -> NDArray[np.float64]:
        return np.concatenate([stage.joint_limits()[1] for stage, _ in self.by_section]).astype(float)

    @cached_property
    def joint_to_boundary(self) -> NDArray[np.float64]:
        """Factor from internal joint units (mm, rad) to boundary units (mm, deg)."""
        return np.array([k.to_boundary for k in self.joint_kinds])

    @cached_property
    def platform_home(self) -> tuple[float, ...]:
        """The closures' unknowns at home, the first guess of the forward kinematics (zeros without any: the
        platform variable of the graphs is then unused and solved in one step)."""
        home = tuple(v for stage in self.stages for v in stage.unknown_home())
        return home or IDENTITY

    @cached_property
    def platform_limits(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(lo, hi) of the closures' unknowns (n_unknowns each): their workspace."""
        lo = [stage.unknown_limits()[0] for stage in self.stages]
        hi = [stage.unknown_limits()[1] for stage in self.stages]
        return np.concatenate(lo).astype(float), np.concatenate(hi).astype(float)

    # -------------------------------------------------------- parameters
    @cached_property
    def parameters(self) -> ParameterTable:
        tol = self.scales
        specs: list[ParameterSpec] = []
        specs += _pose_specs("base", self.base, tol.base_length, tol.base_angle)
        for stage, at in self.by_section:
            group = stage.classic_group if self.is_classic else stage.group
            specs += stage.parameter_specs(at.first_item, tol, group)
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
        n_dh = sum(stage.n_params for stage in self.stages if stage.section is Section.LINKS)
        n_hex = sum(stage.n_params for stage in self.stages if stage.section is Section.LEGS)
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
    """{first} -> {stop}: links first..stop-1 (0-based, across the serial stages) with their joints and
    parameters."""
    links = desc.links[first:stop]
    q0 = sum(link.joint.moves for link in desc.links[:first])
    n_q = sum(link.joint.moves for link in links)
    s = desc.slices["links"]
    p0, p1 = desc.link_param_offsets[first], desc.link_param_offsets[stop]
    return chain_transform(links, q_chain[q0 : q0 + n_q], params[s.start + p0 : s.start + p1])


def stages_transform(desc: RobotDescription, stop: int, q: Sym, platform: Sym, params: Sym) -> Sym:
    """World <- the end frame of stage `stop - 1` (the base alone for 0): base · stage · … for the joints `q`
    (all of them, legs included), the closures' unknowns `platform` and the parameters."""
    t = pose_transform(params[desc.slices["base"]])
    if q.numel() < desc.n_joints:
        # The serial joints alone: a stage with unknowns is placed by them, its legs enter only its closure
        # (`models.stages.base.Stage.transform`), so zeros stand in for the legs.
        pad = desc.n_joints - q.numel()
        q = ca.vertcat(q, ca.SX.zeros(pad) if isinstance(q, ca.SX) else ca.MX.zeros(pad))
    for stage, at in zip(desc.stages[:stop], desc.placements[:stop], strict=True):
        t = t @ stage.transform(q[at.joints], platform[at.unknowns], params[at.params])
    return t


def carriage_transform(desc: RobotDescription, q: Sym, params: Sym) -> Sym:
    """World <- the first parallel stage's start frame (without one: world <- the last link's frame). The
    stages before a parallel one are explicit in their joints (`q`, the serial joints first)."""
    stop = desc.closed_stages[0] if desc.closed_stages else len(desc.stages)
    return stages_transform(desc, stop, q, _no_unknowns(q), params)


def tcp_transform(desc: RobotDescription, q: Sym, platform: Sym, params: Sym) -> Sym:
    """World <- TCP for the joints `q` (all of them, or the serial joints alone: a parallel stage's transform
    is its unknowns', not its legs') and the closures' unknowns `platform` (ignored without a closure)."""
    return stages_transform(desc, len(desc.stages), q, platform, params) @ pose_transform(params[desc.slices["tool"]])


def _no_unknowns(q: Sym) -> Sym:
    return ca.SX(0, 1) if isinstance(q, ca.SX) else ca.MX(0, 1)
