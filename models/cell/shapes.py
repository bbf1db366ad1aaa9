"""Solid shapes of the cell, in mm, each in its own frame, and their collision objects (python-fcl).

A shape is a frozen value: its size and, for a mesh, its triangles. Where it sits is said by who holds it (an
obstacle's pose in the world frame, a link shape's pose in its link frame). `collision_geometry` builds the
library's object once per shape value; the feasibility check only moves it.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import fcl  # type: ignore[import-untyped]
import numpy as np

from models._types import Array
from models.errors import InvalidInput


def _positive(value: float, name: str, *, zero: bool = False) -> None:
    if not np.isfinite(value) or value < 0 or (value == 0 and not zero):
        raise InvalidInput(f"{name} must be {'non-negative' if zero else 'positive'} (mm), got {value}", field=name)


@dataclass(frozen=True)
class Box:
    """A box centred on its frame's origin, edges along its axes: full sizes (mm)."""

    x: float
    y: float
    z: float

    def __post_init__(self) -> None:
        for name in ("x", "y", "z"):
            _positive(getattr(self, name), f"box.{name}")

    @property
    def bounding_radius(self) -> float:
        return 0.5 * float(np.linalg.norm((self.x, self.y, self.z)))

    @property
    def half_extents(self) -> tuple[float, float, float]:
        return (0.5 * self.x, 0.5 * self.y, 0.5 * self.z)


@dataclass(frozen=True)
class Cylinder:
    """A cylinder centred on its frame's origin, its axis along z: radius and full length (mm)."""

    radius: float
    length: float

    def __post_init__(self) -> None:
        _positive(self.radius, "cylinder.radius")
        _positive(self.length, "cylinder.length")

    @property
    def bounding_radius(self) -> float:
        return float(np.hypot(self.radius, 0.5 * self.length))

    @property
    def half_extents(self) -> tuple[float, float, float]:
        return (self.radius, self.radius, 0.5 * self.length)


@dataclass(frozen=True)
class Sphere:
    radius: float

    def __post_init__(self) -> None:
        _positive(self.radius, "sphere.radius")

    @property
    def bounding_radius(self) -> float:
        return self.radius

    @property
    def half_extents(self) -> tuple[float, float, float]:
        return (self.radius, self.radius, self.radius)


@dataclass(frozen=True)
class Capsule:
    """Points within `radius` of the segment of `length` along z centred on the origin (mm)."""

    radius: float
    length: float

    def __post_init__(self) -> None:
        _positive(self.radius, "capsule.radius")
        _positive(self.length, "capsule.length", zero=True)

    @property
    def bounding_radius(self) -> float:
        return self.radius + 0.5 * self.length

    @property
    def half_extents(self) -> tuple[float, float, float]:
        return (self.radius, self.radius, self.radius + 0.5 * self.length)


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh: vertices (mm) and triangles (vertex indices), as tuples so that the value is hashable."""

    vertices: tuple[tuple[float, float, float], ...]
    triangles: tuple[tuple[int, int, int], ...]

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        t = np.asarray(self.triangles, dtype=int)
        if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] < 3 or not np.isfinite(v).all():
            raise InvalidInput("a mesh needs at least 3 finite vertices of 3 coordinates", field="mesh.vertices")
        if t.ndim != 2 or t.shape[1] != 3 or t.shape[0] < 1 or t.min() < 0 or t.max() >= v.shape[0]:
            raise InvalidInput("a mesh's triangles are 3 indices each into its vertices", field="mesh.triangles")

    @classmethod
    def of(cls, vertices: Array, triangles: Array) -> Mesh:
        return cls(
            tuple(tuple(float(c) for c in row) for row in np.asarray(vertices, dtype=float)),  # type: ignore[misc]
            tuple(tuple(int(c) for c in row) for row in np.asarray(triangles, dtype=int)),  # type: ignore[misc]
        )

    @property
    def bounding_radius(self) -> float:
        return float(np.linalg.norm(np.asarray(self.vertices), axis=1).max())

    @property
    def half_extents(self) -> tuple[float, float, float]:
        """Of the box centred on the mesh's origin that holds it (a conservative bound for the checks)."""
        h = np.abs(np.asarray(self.vertices)).max(axis=0)
        return (float(h[0]), float(h[1]), float(h[2]))


Shape = Box | Cylinder | Sphere | Capsule | Mesh
"""What an obstacle or a link is made of."""


@lru_cache(maxsize=4096)
def collision_geometry(shape: Shape) -> object:
    """The library's geometry of `shape` (built once per value; capsules of zero length are spheres)."""
    if isinstance(shape, Box):
        return fcl.Box(shape.x, shape.y, shape.z)
    if isinstance(shape, Cylinder):
        return fcl.Cylinder(shape.radius, shape.length)
    if isinstance(shape, Sphere):
        return fcl.Sphere(shape.radius)
    if isinstance(shape, Capsule):
        return capsule_geometry(shape.radius, shape.length)
    model = fcl.BVHModel()
    v, t = np.asarray(shape.vertices, dtype=float), np.asarray(shape.triangles, dtype=np.int64)
    model.beginModel(v.shape[0], t.shape[0])
    model.addSubModel(v, t)
    model.endModel()
    return model


@lru_cache(maxsize=65536)
def capsule_geometry(radius: float, length: float) -> object:
    """A capsule's geometry by its numbers (the checks make one per segment length, unvalidated: their lengths
    come from the model, their radii from a validated shape)."""
    return fcl.Capsule(radius, length) if length > 0 else fcl.Sphere(radius)
