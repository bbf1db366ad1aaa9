"""Named geometric parameters: the calibration unknowns.

Each parameter has a kind (a length in mm or an angle, rad inside / degrees at
the boundary), a nominal value and a scale. The scale is the expected size of
its error (a manufacturing tolerance); identification and pose design divide
Jacobian columns by it so that "one unit" means the same for every parameter.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from enum import StrEnum
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models.errors import UnknownParameter, WrongShape


@dataclass(frozen=True)
class ParameterScales:
    """Expected error sizes per kind of parameter (internal units: mm, rad).

    Identification and pose design multiply Jacobian columns by them, so that "one unit" of every parameter
    is one expected error. Not the tolerance study's magnitudes (`models.error_analysis`).
    """

    base_length: float = 1.0
    base_angle: float = float(np.radians(0.1))
    dh_length: float = 0.5
    dh_angle: float = float(np.radians(0.1))
    hexapod_joint: float = 0.1
    leg_offset: float = 0.5
    tool_length: float = 0.5
    tool_angle: float = float(np.radians(0.2))
    thermal: float = 5e-6
    """κ (1/K): the spread of expansion coefficients between steels and a leg's mix of steel and aluminium."""
    compliance: float = 1e-4
    """A leg's compliance, mm/N (0.1 µm/N)."""
    joint_compliance: float = 1e-5
    """A revolute joint's angular compliance, rad/(N·m) (10 µrad/(N·m))."""


GROUP_ALIASES: dict[str, str] = {"carriage": "links", "links": "carriage", "hexapod": "legs", "legs": "hexapod"}
"""The IWR names its links `carriage` and its legs `hexapod`; every robot accepts both names of each group."""


class Kind(StrEnum):
    LENGTH = "length"
    ANGLE = "angle"
    THERMAL = "thermal"
    """An expansion coefficient: 1/K inside, ppm/K at the boundary."""
    COMPLIANCE = "compliance"
    """A leg's compliance: mm/N inside, µm/N at the boundary."""
    JOINT_COMPLIANCE = "joint_compliance"
    """A revolute joint's angular compliance: rad/(N·m) inside, µrad/(N·m) at the boundary."""

    @property
    def boundary_unit(self) -> str:
        return _BOUNDARY_UNITS[self]

    @property
    def to_boundary(self) -> float:
        """Factor from internal units (mm, rad, 1/K, mm/N) to boundary units (mm, deg, ppm/K, µm/N)."""
        return _TO_BOUNDARY[self]


_BOUNDARY_UNITS = {
    Kind.LENGTH: "mm",
    Kind.ANGLE: "deg",
    Kind.THERMAL: "ppm/K",
    Kind.COMPLIANCE: "µm/N",
    Kind.JOINT_COMPLIANCE: "µrad/(N·m)",
}
_TO_BOUNDARY = {
    Kind.LENGTH: 1.0,
    Kind.ANGLE: float(np.degrees(1.0)),
    Kind.THERMAL: 1e6,
    Kind.COMPLIANCE: 1e3,
    Kind.JOINT_COMPLIANCE: 1e6,
}


@dataclass(frozen=True)
class ParameterSpec:
    name: str
    group: str
    kind: Kind
    nominal: float
    """Internal units: mm or rad."""
    scale: float
    """Expected error size, internal units; > 0."""

    @property
    def unit(self) -> str:
        return self.kind.boundary_unit


@dataclass(frozen=True)
class ParameterTable:
    """The ordered parameter list of one robot description."""

    specs: tuple[ParameterSpec, ...]

    def __len__(self) -> int:
        return len(self.specs)

    @cached_property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    @cached_property
    def index(self) -> dict[str, int]:
        return {name: i for i, name in enumerate(self.names)}

    @cached_property
    def groups(self) -> dict[str, tuple[int, ...]]:
        out: dict[str, list[int]] = {}
        for i, s in enumerate(self.specs):
            out.setdefault(s.group, []).append(i)
        return {g: tuple(ix) for g, ix in out.items()}

    @property
    def nominal(self) -> NDArray[np.float64]:
        return np.array([s.nominal for s in self.specs])

    @property
    def scales(self) -> NDArray[np.float64]:
        return np.array([s.scale for s in self.specs])

    @cached_property
    def to_boundary(self) -> NDArray[np.float64]:
        """Per-parameter factor from internal to boundary units."""
        return np.array([s.kind.to_boundary for s in self.specs])

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(s.unit for s in self.specs)

    def indices(self, names_or_groups: Iterable[str]) -> tuple[int, ...]:
        """Indices for a mix of parameter names and group names, in table order.

        The groups of `shared/spec/robots.md` (`base`, `links`, `legs`, `tool`) and the IWR's names of two of
        them (`carriage`, `hexapod`) are valid for every robot; a robot without legs has an empty `legs`.
        """
        chosen: set[int] = set()
        for key in names_or_groups:
            if key in self.groups:
                chosen.update(self.groups[key])
            elif key in GROUP_ALIASES:
                chosen.update(self.groups.get(GROUP_ALIASES[key], ()))
            elif key in self.index:
                chosen.add(self.index[key])
            else:
                raise UnknownParameter(
                    f"unknown parameter or group {key!r}; groups are {sorted(self.groups)}",
                    name=key,
                )
        return tuple(sorted(chosen))

    def vector(self, values: ArrayLike) -> NDArray[np.float64]:
        """Validate a full parameter vector in internal units."""
        vec = np.asarray(values, dtype=float).reshape(-1)
        if vec.shape != (len(self),):
            raise WrongShape(
                f"expected {len(self)} parameters, got {vec.size}", field="params", expected=[len(self)], got=[vec.size]
            )
        return vec

    def with_values(self, base: ArrayLike, updates: dict[str, float]) -> NDArray[np.float64]:
        """Copy of `base` with some parameters replaced (internal units)."""
        vec = self.vector(base).copy()
        for name, value in updates.items():
            if name not in self.index:
                raise UnknownParameter(f"unknown parameter {name!r}", name=name)
            vec[self.index[name]] = value
        return vec

    def from_boundary(self, values: Sequence[float]) -> NDArray[np.float64]:
        return self.vector(values) / self.to_boundary

    def as_boundary(self, values: ArrayLike) -> NDArray[np.float64]:
        return self.vector(values) * self.to_boundary
