"""A robot as a tree of chains: named branches of stages, one base, a tool at the end of each tip branch.

A cell is not one chain: a dual-arm torso turns both arms on one waist joint, a positioner holds the part beside
the arm on one floor, a track carries an arm. A `Branch` is a chain of stages (`models.stages`: serial links,
a hexapod) hanging from the end frame of its parent branch, or from the base; it may start at a fixed `mount`
(the shoulder on the torso, the positioner on the floor, `models.tree.mount`) and may end in a tool. Every tool
is reached by one path of branches from the base, and that path is an ordinary `RobotDescription` (`chain`):
the base, the path's stages, the tool. Its compiled Functions are the existing runtime's, built once per
structure (both arms of a symmetric torso share one build).

The tree's global vectors hold each thing once: the parameters are the base's six, then each branch's own
(its mount, its links), then each tool's six; the joints are each branch's, in branch order, so a waist joint
shared by two arms is one column. `selection(tip)` says where each of a chain's parameters and joints sits in
them: a chain's forward kinematics and Jacobian are the tree's, scattered by that map (`models.tree.kinematics`).

Names: `base.x`; `{branch}.mount.x`, `{branch}.link{i}.theta` (links numbered within the branch),
`{branch}.leg{i}.offset`; `{branch}.tool.x`. Groups: `base`, each branch's name (its mount and links), and
`{branch}.tool`. Joints: the branch's own names when given (a URDF's), else `{branch}.q{k}`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from models._types import IDENTITY, Array, Pose6
from models.description.parameters import Kind, ParameterScales, ParameterSpec, ParameterTable
from models.description.robot import RobotDescription
from models.errors import InvalidInput
from models.stages import Section, Stage
from models.tree.mount import MountStage

POSE_FIELDS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class Branch:
    """One chain of stages of a tree (see the module docstring)."""

    name: str
    stages: tuple[Stage, ...]
    parent: str | None = None
    """The branch whose end frame this one starts from; None: the tree's base frame."""
    mount: Pose6 | None = None
    """Parent frame <- this branch's first frame (mm, rotation vector); None: its first link is written in the
    parent's end frame directly, as a chain's next link would be."""
    tool: Pose6 | None = None
    """End frame -> its tool (mm, rotation vector); None: a branch that only carries others (a waist, a track)."""
    joint_names: tuple[str, ...] | None = None
    """Its joints' names (a URDF's); None: `{name}.q1` …"""

    @cached_property
    def own_stages(self) -> tuple[Stage, ...]:
        """Its mount (when it has one) and its stages: what it adds to every chain through it."""
        return ((MountStage(self.mount),) if self.mount is not None else ()) + tuple(self.stages)

    @property
    def n_joints(self) -> int:
        return sum(stage.n_joints for stage in self.stages)


@dataclass(frozen=True)
class TipMap:
    """Where a tip's chain sits in the tree's global vectors: chain index -> global index."""

    params: NDArray[np.intp]
    joints: NDArray[np.intp]


@dataclass(frozen=True)
class RobotTree:
    """Branches in order (a parent before its children), one base, a tool per tip branch."""

    name: str
    branches: tuple[Branch, ...]
    base: Pose6 = IDENTITY
    """World (the instrument) <- the tree's base frame: x, y, z (mm), rotation vector (rad)."""
    scales: ParameterScales = field(default_factory=ParameterScales)

    def __post_init__(self) -> None:
        check_branches(self.branches)

    @cached_property
    def by_name(self) -> dict[str, Branch]:
        return {branch.name: branch for branch in self.branches}

    @cached_property
    def tips(self) -> tuple[str, ...]:
        """The branches that end in a tool, in branch order: the tree's tools are named by them."""
        return tuple(branch.name for branch in self.branches if branch.tool is not None)

    def branch(self, name: str, field: str = "tool") -> Branch:
        """The branch `name`; InvalidInput naming the branches when there is none."""
        found = self.by_name.get(name)
        if found is None:
            raise _none_of(
                self.by_name, name, field, f"the tree {self.name!r} has no branch {name!r}; its branches are"
            )
        return found

    def tip(self, name: str, field: str = "tool") -> Branch:
        """The tip branch `name`; InvalidInput naming the tools when it is not one."""
        found = self.branch(name, field)
        if found.tool is None:
            raise _none_of(self.tips, name, field, f"branch {name!r} has no tool; the tree's tools are")
        return found

    def joint_index(self, name: str, field: str) -> int:
        """The index of joint `name` in the global joint vector; InvalidInput naming the joints when there is none."""
        if name not in self._joint_indices:
            raise _none_of(self.joint_names, name, field, f"{field}: the tree has no joint {name!r}; its joints are")
        return self._joint_indices[name]

    @cached_property
    def _joint_indices(self) -> dict[str, int]:
        return {name: j for j, name in enumerate(self.joint_names)}

    def check_record(self, tool: str, frame: str | None, where: str) -> None:
        """A record of tool `tool` in tool `frame`'s frame (None: the instrument's) names tips of the tree, and not
        the same one twice; InvalidInput naming `where` (the record's place, e.g. "fixed[3]") otherwise."""
        self.tip(tool, f"{where}.tool")
        if frame is not None:
            self.tip(frame, f"{where}.frame")
            if frame == tool:
                raise InvalidInput(f"{where}: a tool measured in its own frame says nothing", field=f"{where}.frame")

    def path(self, name: str) -> tuple[Branch, ...]:
        """The branches from the base to `name`, in order."""
        out = [self.branch(name)]
        while out[-1].parent is not None:
            out.append(self.by_name[out[-1].parent])
        return tuple(reversed(out))

    # ------------------------------------------------------------------ the global vectors
    @cached_property
    def _layout(self) -> tuple[dict[tuple[str, int], tuple[slice, slice]], dict[str, slice], int, int]:
        """(branch, own stage index) -> (its global parameters, its global joints); tool slices; sizes."""
        stages: dict[tuple[str, int], tuple[slice, slice]] = {}
        p, j = 6, 0
        for branch in self.branches:
            for k, stage in enumerate(branch.own_stages):
                stages[branch.name, k] = (slice(p, p + stage.n_params), slice(j, j + stage.n_joints))
                p, j = p + stage.n_params, j + stage.n_joints
        tools = {}
        for name in self.tips:
            tools[name] = slice(p, p + 6)
            p += 6
        return stages, tools, p, j

    @property
    def n_params(self) -> int:
        return self._layout[2]

    @property
    def n_joints(self) -> int:
        return self._layout[3]

    def stage_params(self, branch: str, k: int) -> slice:
        """The global parameters of the k-th of `branch`'s own stages (its mount first, when it has one)."""
        return self._layout[0][self.branch(branch, "branch").name, k][0]

    def stage_joints(self, branch: str, k: int) -> slice:
        """The global joints of the k-th of `branch`'s own stages (its mount first, when it has one)."""
        return self._layout[0][self.branch(branch, "branch").name, k][1]

    def tool_slice(self, tip: str) -> slice:
        return self._layout[1][self.tip(tip).name]

    @cached_property
    def parameters(self) -> ParameterTable:
        """The global parameter table (see the module docstring for names and groups)."""
        tol = self.scales
        specs = _pose_specs("base", "base", self.base, tol.base_length, tol.base_angle)
        for branch in self.branches:
            # Links and legs are numbered apart, as in a chain (`link1`, `leg1`), but within the branch.
            first = {Section.LINKS: 1, Section.LEGS: 1}
            for stage in branch.own_stages:
                for spec in stage.parameter_specs(first[stage.section], tol, branch.name):
                    specs.append(
                        ParameterSpec(f"{branch.name}.{spec.name}", branch.name, spec.kind, spec.nominal, spec.scale)
                    )
                first[stage.section] += stage.n_items
        for name in self.tips:
            tool = self.by_name[name].tool
            assert tool is not None
            specs += _pose_specs(f"{name}.tool", f"{name}.tool", tool, tol.tool_length, tol.tool_angle)
        return ParameterTable(tuple(specs))

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        names: list[str] = []
        for branch in self.branches:
            names += branch.joint_names or [f"{branch.name}.q{k}" for k in range(1, branch.n_joints + 1)]
        return tuple(names)

    @cached_property
    def joint_kinds(self) -> tuple[Kind, ...]:
        return tuple(kind for branch in self.branches for stage in branch.stages for kind in stage.joint_kinds())

    @cached_property
    def joint_limits(self) -> tuple[Array, Array]:
        """(lo, hi) of the global joints, internal units."""
        limits = [stage.joint_limits() for branch in self.branches for stage in branch.stages]
        return (
            np.concatenate([lo for lo, _ in limits]).astype(float),
            np.concatenate([hi for _, hi in limits]).astype(float),
        )

    # ------------------------------------------------------------------ the chains
    def chain(self, tip: str) -> RobotDescription:
        """The ordinary chain of `tip`: the base, the stages of the branches on its path, its tool."""
        return self._chains[self.tip(tip).name][0]

    def selection(self, tip: str) -> TipMap:
        """Where the chain of `tip` sits in the global vectors (chain index -> global index)."""
        return self._chains[self.tip(tip).name][1]

    @cached_property
    def _chains(self) -> dict[str, tuple[RobotDescription, TipMap]]:
        return {name: self._build_chain(name) for name in self.tips}

    def _build_chain(self, tip: str) -> tuple[RobotDescription, TipMap]:
        stage_slices, tools, _, _ = self._layout
        owners = [(b.name, k, stage) for b in self.path(tip) for k, stage in enumerate(b.own_stages)]
        tool = self.by_name[tip].tool
        assert tool is not None
        desc = RobotDescription(
            name=f"{self.name}:{tip}",
            stages=tuple(stage for _, _, stage in owners),
            base=self.base,
            tool=tool,
            scales=self.scales,
        )
        params = np.empty(desc.n_params, dtype=np.intp)
        joints = np.empty(desc.n_joints, dtype=np.intp)
        params[desc.slices["base"]] = np.arange(6)
        params[desc.slices["tool"]] = np.arange(tools[tip].start, tools[tip].stop)
        for (branch, k, _), placement in zip(owners, desc.placements, strict=True):
            p, j = stage_slices[branch, k]
            params[placement.params] = np.arange(p.start, p.stop)
            joints[placement.joints] = np.arange(j.start, j.stop)
        return desc, TipMap(params, joints)


def _pose_specs(prefix: str, group: str, pose: Pose6, length: float, angle: float) -> list[ParameterSpec]:
    return [
        ParameterSpec(
            f"{prefix}.{name}", group, Kind.LENGTH if k < 3 else Kind.ANGLE, float(pose[k]), length if k < 3 else angle
        )
        for k, name in enumerate(POSE_FIELDS)
    ]


def check_branches(branches: tuple[Branch, ...]) -> None:
    """InvalidInput naming the branch and the fix: unique names, parents declared before their children, a
    tool somewhere, and joint names that match the joints."""
    seen: set[str] = set()
    for i, branch in enumerate(branches):
        where = f"branches[{i}]"
        if not branch.name or "." in branch.name:
            raise InvalidInput(
                f"branch {branch.name!r}: a branch needs a non-empty name without '.' (it prefixes its parameters)",
                field=f"{where}.name",
            )
        if branch.name in seen:
            raise InvalidInput(f"two branches are named {branch.name!r}: rename one", field=f"{where}.name")
        if branch.parent is not None and branch.parent not in seen:
            raise InvalidInput(
                f"branch {branch.name!r} hangs from {branch.parent!r}, which is not a branch declared before it: "
                "declare the parent first",
                field=f"{where}.parent",
                value=branch.parent,
            )
        if branch.joint_names is not None and len(branch.joint_names) != branch.n_joints:
            raise InvalidInput(
                f"branch {branch.name!r} has {branch.n_joints} joints and {len(branch.joint_names)} joint names",
                field=f"{where}.joint_names",
            )
        if not branch.stages and branch.tool is None:
            raise InvalidInput(f"branch {branch.name!r} has neither stages nor a tool", field=f"{where}.stages")
        seen.add(branch.name)
    if not any(branch.tool is not None for branch in branches):
        raise InvalidInput("a tree needs at least one branch with a tool", field="branches")


def _none_of(names: Iterable[str], name: str, field: str, detail: str) -> InvalidInput:
    """`name` is none of `names`: `detail` then the names, which the error also carries for a client to offer."""
    allowed = list(names)
    return InvalidInput(f"{detail} {allowed}", field=field, value=name, allowed=allowed)
