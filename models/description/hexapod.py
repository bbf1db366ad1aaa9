"""A Stewart–Gough hexapod with six UPS legs, symbolic in its geometry.

Leg `i` joins base joint `a_i` (frame {4}) to platform joint `b_i` (frame
{5}); its vector is `p + R b_i − a_i` (thesis eq. 18) and its length equals the
commanded length plus the leg offset. The platform pose `x = [p (mm); α, β, γ
(rad)]` uses `R = Rz(α) Ry(β) Rx(γ)`.

Inverse kinematics (pose → legs) is closed form. Forward kinematics (legs →
pose) is the root of the six closure equations, solved by Newton (see
`symbolic`); CasADi differentiates it through the implicit function
theorem.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca

from models.description.parameters import Kind, ParameterSpec
from models.transforms import Sym, euler_zyx

Vec3 = tuple[float, float, float]
Pose6 = tuple[float, float, float, float, float, float]

LEG_FIELDS: tuple[str, ...] = ("a.x", "a.y", "a.z", "b.x", "b.y", "b.z", "offset")
PARAMS_PER_LEG = len(LEG_FIELDS)
N_LEGS = 6


@dataclass(frozen=True)
class HexapodGeometry:
    base_joints: tuple[Vec3, ...]
    """a_i in frame {4}, mm."""
    platform_joints: tuple[Vec3, ...]
    """b_i in frame {5}, mm."""
    leg_offsets: tuple[float, ...]
    stroke_min: float | tuple[float, ...]
    stroke_max: float | tuple[float, ...]
    """One stroke for every leg, or one per leg (mm)."""
    home: Pose6
    """Platform pose used as the Newton seed: mm and rad."""
    workspace_min: Pose6
    workspace_max: Pose6
    max_condition: float
    """Poses whose (length-scaled) hexapod Jacobian is worse conditioned than this are 'near singular'."""

    @property
    def stroke_mins(self) -> tuple[float, ...]:
        return _per_leg(self.stroke_min)

    @property
    def stroke_maxs(self) -> tuple[float, ...]:
        return _per_leg(self.stroke_max)

    @property
    def characteristic_length(self) -> float:
        """Platform radius: turns rotations into lengths so the Jacobian's condition number has no unit."""
        return max(float(sum(c * c for c in b) ** 0.5) for b in self.platform_joints)


def _per_leg(value: float | tuple[float, ...]) -> tuple[float, ...]:
    return tuple(float(v) for v in value) if isinstance(value, tuple) else (float(value),) * N_LEGS


def hexapod_parameter_specs(
    geometry: HexapodGeometry, joint_scale: float, offset_scale: float, group: str = "hexapod", first: int = 1
) -> list[ParameterSpec]:
    """The legs' parameters, named `leg{i}.{field}` from i = `first` (legs are numbered across stages)."""
    specs = []
    for i in range(first - 1, first - 1 + N_LEGS):
        k = i - first + 1
        values = (*geometry.base_joints[k], *geometry.platform_joints[k], geometry.leg_offsets[k])
        for field, value in zip(LEG_FIELDS, values, strict=True):
            specs.append(
                ParameterSpec(
                    name=f"leg{i + 1}.{field}",
                    group=group,
                    kind=Kind.LENGTH,
                    nominal=float(value),
                    scale=offset_scale if field == "offset" else joint_scale,
                )
            )
    return specs


def split_hexapod_params(params: Sym) -> tuple[Sym, Sym, Sym]:
    """(a: 3x6, b: 3x6, offsets: 6) from the 42 hexapod parameters."""
    per_leg = ca.reshape(params, PARAMS_PER_LEG, N_LEGS)
    return per_leg[0:3, :], per_leg[3:6, :], per_leg[6, :].T


def platform_rotation(x: Sym) -> Sym:
    return euler_zyx(x[3], x[4], x[5])


def leg_vectors(x: Sym, params: Sym) -> Sym:
    """3x6 leg vectors a_i -> b_i in frame {4}."""
    a, b, _ = split_hexapod_params(params)
    p = x[0:3]
    r = platform_rotation(x)
    return ca.repmat(p, 1, N_LEGS) + r @ b - a


def actuator_lengths(x: Sym, params: Sym) -> Sym:
    """Closed-form inverse kinematics: the commanded leg lengths (6) for platform pose x."""
    v = leg_vectors(x, params)
    _, _, offsets = split_hexapod_params(params)
    return ca.sqrt(ca.sum1(v * v)).T - offsets


def closure_residual(x: Sym, legs: Sym, params: Sym) -> Sym:
    """Zero when the platform pose x is consistent with the commanded legs (mm)."""
    return actuator_lengths(x, params) - legs


def thesis_jacobian(x: Sym, params: Sym) -> Sym:
    """Eq. 48: rows [u_iᵀ, (s_i × u_i)ᵀ], u_i the unit leg vector and s_i = R b_i.

    Maps a platform twist (δp, δΩ in frame {4}) to leg length changes.
    """
    v = leg_vectors(x, params)
    _, b, _ = split_hexapod_params(params)
    s = platform_rotation(x) @ b
    rows = []
    for i in range(N_LEGS):
        u = v[:, i] / ca.norm_2(v[:, i])
        rows.append(ca.horzcat(u.T, ca.cross(s[:, i], u).T))
    return ca.vertcat(*rows)
