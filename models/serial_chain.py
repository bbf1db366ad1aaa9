"""A standard Denavit–Hartenberg serial chain, symbolic in joints and parameters.

`A_i = Rz(theta_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i)` (thesis eq. 1). For a
revolute joint the encoder reading adds to `theta_i`, for a prismatic one to
`d_i`; the other of the two is a constant. Every one of the four numbers per
link is a parameter, so joint offsets are identified like any DH constant.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import casadi as ca

from models.parameters import Kind, ParameterSpec
from models.transforms import Sym, homogeneous, rot_x, rot_z


class JointType(StrEnum):
    PRISMATIC = "prismatic"
    REVOLUTE = "revolute"

    @property
    def kind(self) -> Kind:
        return Kind.LENGTH if self is JointType.PRISMATIC else Kind.ANGLE


@dataclass(frozen=True)
class DHLink:
    """One link: nominal DH numbers (mm, rad) and the joint's range (mm or rad)."""

    joint: JointType
    theta: float
    d: float
    a: float
    alpha: float
    joint_min: float
    joint_max: float


# Order of a link's parameters in the parameter vector (spec: theta, d, a, alpha).
DH_FIELDS: tuple[str, ...] = ("theta", "d", "a", "alpha")
DH_KINDS: tuple[Kind, ...] = (Kind.ANGLE, Kind.LENGTH, Kind.LENGTH, Kind.ANGLE)


def dh_parameter_specs(links: tuple[DHLink, ...], length_scale: float, angle_scale: float) -> list[ParameterSpec]:
    specs = []
    for i, link in enumerate(links, start=1):
        for field, kind in zip(DH_FIELDS, DH_KINDS, strict=True):
            specs.append(
                ParameterSpec(
                    name=f"link{i}.{field}",
                    group="carriage",
                    kind=kind,
                    nominal=float(getattr(link, field)),
                    scale=length_scale if kind is Kind.LENGTH else angle_scale,
                )
            )
    return specs


def dh_transform(theta: Sym, d: Sym, a: Sym, alpha: Sym) -> Sym:
    rz = homogeneous(rot_z(theta), ca.vertcat(0, 0, 0))
    tz_tx_rx = homogeneous(rot_x(alpha), ca.vertcat(a, 0, d))
    # Tz(d)·Tx(a)·Rx(alpha) is a pure translation (a, 0, d) followed by Rx.
    return rz @ tz_tx_rx


def chain_transform(links: tuple[DHLink, ...], q: Sym, params: Sym) -> Sym:
    """Transform {0} -> {n} for joint values `q` (n) and parameters (4n: theta, d, a, alpha per link)."""
    t = None
    for i, link in enumerate(links):
        theta, d, a, alpha = (params[4 * i + k] for k in range(4))
        if link.joint is JointType.REVOLUTE:
            theta = theta + q[i]
        else:
            d = d + q[i]
        a_i = dh_transform(theta, d, a, alpha)
        t = a_i if t is None else t @ a_i
    assert t is not None, "a chain needs at least one link"
    return t
