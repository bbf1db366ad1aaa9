"""The error magnitudes of the tolerance study, and of the simulated robots.

One type for the thesis's four numbers (§4.5): the study draws its parameter
errors from them, `models.simulation` perturbs its "true" robots with them.
Not `models.description.parameters.ParameterScales`, the expected error sizes that scale the
identification Jacobian, although their defaults agree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from numpy.typing import NDArray

from models.description.parameters import Kind
from models.description.robot import RobotDescription
from models.errors import InvalidInput

_DEG = float(np.degrees(1.0))


@dataclass(frozen=True)
class ErrorMagnitudes:
    """Error magnitudes, internal units (mm, rad); defaults are the thesis's (§4.5).

    Each number is the size of the error of every parameter it covers, per
    coordinate: `joint_position` applies to each of x, y, z of every base
    joint `a_i` and platform joint `b_i`.
    """

    leg_offset: float = 0.5
    """|δL|, mm: each leg's length offset."""
    joint_position: float = 0.1
    """|δP|, mm: each coordinate of a_i and b_i."""
    dh_angle: float = float(np.radians(0.1))
    """|Δα| = |Δθ|, rad: DH twist and joint-angle offset of every link."""
    dh_length: float = 0.5
    """|Δa| = |Δd|, mm: DH length and joint-distance offset of every link."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            number = math.nan if isinstance(value, bool) or not isinstance(value, int | float) else float(value)
            if not math.isfinite(number) or number < 0:
                raise InvalidInput(
                    f"tolerance {f.name} = {value!r} must be a finite number >= 0 (an error magnitude)",
                    field=f.name,
                    value=str(value),
                )

    @classmethod
    def from_boundary(
        cls,
        *,
        leg_offset_mm: float = 0.5,
        joint_position_mm: float = 0.1,
        dh_angle_deg: float = 0.1,
        dh_length_mm: float = 0.5,
    ) -> ErrorMagnitudes:
        """From boundary units (mm, degrees)."""
        return cls(
            leg_offset=leg_offset_mm,
            joint_position=joint_position_mm,
            dh_angle=float(np.radians(dh_angle_deg)),
            dh_length=dh_length_mm,
        )

    def scaled(self, factor: float) -> ErrorMagnitudes:
        return ErrorMagnitudes(
            leg_offset=self.leg_offset * factor,
            joint_position=self.joint_position * factor,
            dh_angle=self.dh_angle * factor,
            dh_length=self.dh_length * factor,
        )

    def vector(self, desc: RobotDescription) -> NDArray[np.float64]:
        """Per-parameter error magnitude (n_params,), internal units; zero for base and tool."""
        out = np.zeros(desc.n_params)
        for i, spec in enumerate(desc.parameters.specs):
            if spec.group in ("carriage", "links"):
                out[i] = self.dh_angle if spec.kind is Kind.ANGLE else self.dh_length
            elif spec.group in ("hexapod", "legs"):
                out[i] = self.leg_offset if spec.name.endswith(".offset") else self.joint_position
        return out
