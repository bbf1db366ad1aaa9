"""What every stage of a robot is: the seam that lets a new kind of stage be one new file.

A robot is base · stage · stage · … · tool (robots.md). A stage is a frozen value that knows its own joints,
parameters, symbolic transform (its start frame -> its end frame), the closure equations that pin its
unknowns (a parallel stage's platform pose; a serial stage has none), its structure token and its document.
It knows nothing of where it sits in the robot's vectors: `RobotDescription` lays the stages out and hands
each its `Placement`, so the same stage value can sit anywhere, and twice.
"""

from __future__ import annotations

import math
from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, ClassVar, Protocol

import casadi as ca
import numpy as np

from models._types import Array
from models.description.parameters import Kind, ParameterScales, ParameterSpec
from models.description.serial_chain import DHLink
from models.transforms import Sym


class Section(IntEnum):
    """Where a stage's joints and parameters go in the robot's vectors.

    robots.md orders the serial joints (and the links' parameters) before the legs, whatever the order of the
    stages in the document: the IWR's 70 parameters and every stored joint vector keep their places.
    """

    LINKS = 0
    LEGS = 1


@dataclass(frozen=True)
class Placement:
    """Where one stage sits in its robot (set by `RobotDescription`)."""

    index: int
    """The stage's position in the document's list."""
    joints: slice
    """Its joints in the joint vector q."""
    unknowns: slice
    """Its unknowns (a platform pose) in the platform vector of the graphs."""
    params: slice
    """Its parameters in the parameter vector."""
    first_item: int
    """1-based number of its first link or leg, in parameter names (`link{i}.d`, `leg{i}.offset`)."""
    first_joint: int
    """1-based number of its first joint, in joint names (`q{k}`, `l{k}`)."""


class Stage(Protocol):
    """One stage of a robot (see the module docstring). Internal units: mm and rad."""

    kind: ClassVar[str]
    """The document's `kind` of this stage."""
    section: ClassVar[Section]
    group: ClassVar[str]
    """The parameter group of its parameters (robots.md: `links`, `legs`)."""
    classic_group: ClassVar[str]
    """The IWR's name of that group (`carriage`, `hexapod`), used when the robot has the IWR's shape."""

    @property
    def n_joints(self) -> int: ...
    @property
    def n_unknowns(self) -> int:
        """Unknowns its closure pins (6 for a platform pose; 0: the stage is explicit in its joints)."""
        ...

    @property
    def n_params(self) -> int: ...
    @property
    def n_items(self) -> int:
        """Links or legs: how far it moves the numbering of the next stage of its section."""
        ...

    @property
    def token(self) -> Hashable:
        """What the compiled graphs depend on: enumerations and counts only, never a number or a user string."""
        ...

    @property
    def moves(self) -> bool:
        """Whether the stage has at least one moving joint."""
        ...

    @property
    def dh_links(self) -> tuple[DHLink, ...]:
        """Its DH/MDH links (none for a parallel stage): what DH exports and joint compliance act on."""
        ...

    def joint_names(self, first: int) -> tuple[str, ...]: ...
    def joint_kinds(self) -> tuple[Kind, ...]: ...
    def joint_limits(self) -> tuple[Array, Array]:
        """(lo, hi) per joint, internal units."""
        ...

    def parameter_specs(self, first: int, scales: ParameterScales, group: str) -> list[ParameterSpec]: ...
    def transform(self, q: Sym, x: Sym, p: Sym) -> Sym:
        """4 x 4: the stage's start frame <- its end frame, for its joints, unknowns and parameters. A stage with
        unknowns is placed by them alone (its joints enter through its closure)."""
        ...

    def closure(self, q: Sym, x: Sym, p: Sym) -> Sym | None:
        """`n_unknowns` equations, zero where the unknowns agree with the joints (None: no unknowns)."""
        ...

    def unknown_home(self) -> tuple[float, ...]:
        """The unknowns' first guess (Newton's seed)."""
        ...

    def unknown_limits(self) -> tuple[Array, Array]:
        """(lo, hi) of the unknowns: their workspace, for sampling and for telling a real assembly."""
        ...

    def joint_expressions(self, x: Sym, p: Sym) -> Sym:
        """Its joints (n_joints) as expressions of its unknowns: the inverse kinematics the IK problem is posed
        with (an empty column without unknowns)."""
        ...

    def joints_of_unknowns(self, x: Array, p: Array) -> Array:
        """(N, n_joints) the joints that put the stage at the unknowns `x` (N, n_unknowns): inverse kinematics
        of a parallel stage, closed form (empty without unknowns)."""
        ...

    def conditioning(self, x: Array, p: Array) -> Array:
        """(N,) a unit-free condition number of the unknowns' equations at `x` (grows without bound near a
        singularity; 1 without unknowns)."""
        ...

    @property
    def max_condition(self) -> float:
        """Poses with a worse `conditioning` are near singular."""
        ...

    def usable(self, q: Array, x: Array, p: Array) -> Array:
        """(N,) bool: the joints are in range and the unknowns far from a singularity (for sampling)."""
        ...

    def document(self, p: Array) -> dict[str, Any]:
        """The stage's robots.md document with the parameter values `p` (its slice, internal units)."""
        ...


class StageReader(Protocol):
    """Reads one stage's document, raising `InvalidInput` with the field's path (`where`)."""

    def __call__(self, raw: Mapping[str, Any], where: str) -> Stage: ...


class WithoutClosure:
    """The closure half of `Stage` for a stage whose end frame follows from its joints in closed form (a serial
    chain, a fixed mount): no closure equations, no unknowns, nothing to condition."""

    @property
    def n_unknowns(self) -> int:
        return 0

    def closure(self, q: Sym, x: Sym, p: Sym) -> Sym | None:
        return None

    def unknown_home(self) -> tuple[float, ...]:
        return ()

    def unknown_limits(self) -> tuple[Array, Array]:
        return np.zeros(0), np.zeros(0)

    def joint_expressions(self, x: Sym, p: Sym) -> Sym:
        return ca.SX(0, 1) if isinstance(p, ca.SX) else ca.MX(0, 1)

    def joints_of_unknowns(self, x: Array, p: Array) -> Array:
        return np.zeros((x.shape[0], 0))

    def conditioning(self, x: Array, p: Array) -> Array:
        return np.ones(x.shape[0])

    @property
    def max_condition(self) -> float:
        return math.inf
