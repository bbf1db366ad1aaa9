"""A laser interferometer's line: the retro-reflector on the tool (at the TCP) moves along a fixed beam, and the
instrument reads the signed distance it travelled along the beam from an unknown zero.

The beam is its origin o (the point where the reading is zero, mm) and its unit direction n, turned from its start
n₀ by two small angles as a plane's normal is (`Plane.normal_at`: α about e₁, β about e₂): five unknowns. With
d = p − o and c = n · d, a record gives four rows: the reading, c − s, and the TCP on the beam, d − c n (three
rows of rank two: the reflector returns the beam only from on it, as a socket's records put the TCP on its
point). A reading alone would not see the direction: along a straight beam a tilt of n changes every reading by
the same amount, which the zero absorbs; the rows across the beam see it, and the origin across the beam.
A reading is a length, so the records fix the scale; they move with the base, so they fix no frame.

The rows depend on the TCP position alone: their θ-derivatives come from the position rows of the forward
kinematics' Jacobian (`forward_kinematics(..., jacobian=True)`, the compiled symbolic model); the derivatives by
α, β and o are written out here, none depending on the reading (so pose design, which knows no readings, has
them whole); tests/models/test_line_measurement.py checks them against finite differences.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from models._types import Array
from models.description.parameters import ParameterSpec
from models.errors import InvalidInput
from models.kinematics import ForwardJacobianResult, ForwardResult
from models.measurements.references import Plane, ReferenceBase, Traits, direction_specs, position_specs

MIN_LINE_TRAVEL_MM = 5.0
"""The records must spread at least this (RMS) along the beam, or its direction is not determined (an
interferometer's travel is tens to thousands of millimetres)."""


@dataclass(frozen=True)
class Line(ReferenceBase):
    """An interferometer's beam; `direction` its start (n₀, any length), `origin` its start (mm, world frame)."""

    name: str
    direction: tuple[float, float, float]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)

    traits: ClassVar[Traits] = Traits("line", rows=4, value_columns=1, fixes_frame=False, fixes_scale=True)

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        group = f"line.{self.name}"
        return direction_specs(group) + position_specs(group, np.asarray(self.origin))

    @property
    def minimum_records(self) -> int:
        return 3

    def direction_at(self, alpha: float, beta: float) -> tuple[Array, Array, Array]:
        """(n, ∂n/∂α, ∂n/∂β): the start direction turned as a plane's normal is (the same parametrisation)."""
        return Plane(self.name, self.direction, 0.0).normal_at(alpha, beta)

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        p, dp = tcp.positions, tcp.jacobians[:, :3, :]
        n, dn_a, dn_b = self.direction_at(float(u[0]), float(u[1]))
        d = p - u[None, 2:5]
        c = d @ n
        across = np.eye(3) - np.outer(n, n)
        r = np.hstack([(c - values)[:, None], d - c[:, None] * n])
        d_theta = np.concatenate([np.einsum("k,nkp->np", n, dp)[:, None, :], np.einsum("jk,nkp->njp", across, dp)], 1)
        size = p.shape[0]
        d_u = np.zeros((size, 4, 5))
        for k, dn in enumerate((dn_a, dn_b)):
            dc = d @ dn
            d_u[:, 0, k] = dc
            d_u[:, 1:, k] = -dc[:, None] * n - c[:, None] * dn
        d_u[:, 0, 2:] = -n
        d_u[:, 1:, 2:] = -across
        return r, d_theta, d_u

    def started(self, tcp: ForwardResult, values: Array) -> Line:
        """The beam through the records' TCP positions (their principal axis), pointing the way the readings grow,
        its origin where the records put the reading's zero."""
        p = tcp.positions
        centre = p.mean(axis=0)
        _, s, vt = np.linalg.svd(p - centre)
        travel = float(s[0]) / np.sqrt(p.shape[0])
        if travel < MIN_LINE_TRAVEL_MM:
            raise InvalidInput(
                f"line {self.name!r}: the records spread {travel:.2g} mm RMS along the beam; move the reflector at "
                f"least {MIN_LINE_TRAVEL_MM:g} mm either way along it, or its direction is not determined",
                field="measurements",
                reason="short_travel",
            )
        n = vt[0]
        if float(((p - centre) @ n) @ (values - values.mean())) < 0:
            n = -n  # the readings grow along the direction
        nx, ny, nz = (float(v) for v in n)
        ox, oy, oz = (float(v) for v in (p - values[:, None] * n).mean(axis=0))
        return Line(self.name, (nx, ny, nz), (ox, oy, oz))
