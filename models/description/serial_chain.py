"""Serial chains in standard or modified Denavit–Hartenberg form, symbolic in joints and parameters.

- standard (`dh`, thesis eq. 1, the IWR's carriage): `A_i = Rz(theta_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i)`;
- modified (`mdh`, Craig): `A_i = Rx(alpha_i) · [Ry(beta_i)] · Tx(a_i) · Rz(theta_i) · Tz(d_i)`.

A revolute joint's reading adds to `theta_i`, a prismatic one's to `d_i`; a fixed link has no joint. Every
number of a link is a parameter, so joint offsets are identified like any DH constant.

Hayati's `beta`: when an `mdh` link's axis is parallel to the previous one (`alpha` = 0 or ±180°), a tiny
tilt of the axis moves the common normal, and so `d`, arbitrarily far: the DH numbers are not a smooth
function of the geometry there. Such a link gets a fifth parameter, a rotation `beta` about the link's y axis
after `Rx(alpha)` (nominal 0), which takes the tilt instead (`shared/spec/robots.md`).

Standard DH has the same defect: a `dh` link whose `alpha` is 0 or ±180° (its axis parallel to the next one)
cannot represent a tilt of one towards the other, so a DH arm with parallel consecutive axes loses one
identifiable parameter per pair (the UR5's shoulder, elbow and wrist: two). An addition to robots.md (the
spec gives `beta` to `mdh` links only): a `dh` link with parallel axes *may* carry `beta` — when its document
gives the key — and then `A_i = Rz(theta_i) · Tz(d_i) · Tx(a_i) · Rx(alpha_i) · Ry(beta_i)`, Hayati's
parameterisation of the standard convention. Opt-in, so that every DH document stored before keeps its
parameter vector, its names and its structure; with it the DH arm's count is Everett–Hsu–Roth's.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from enum import StrEnum

import casadi as ca

from models.description.parameters import Kind, ParameterSpec
from models.transforms import Sym, homogeneous, rot_x, rot_y, rot_z


class JointType(StrEnum):
    """In the order robots.md and the published schema list them (the service's schema derives from this)."""

    REVOLUTE = "revolute"
    PRISMATIC = "prismatic"
    FIXED = "fixed"

    @property
    def kind(self) -> Kind:
        return Kind.LENGTH if self is JointType.PRISMATIC else Kind.ANGLE

    @property
    def moves(self) -> bool:
        return self is not JointType.FIXED


class Convention(StrEnum):
    DH = "dh"
    MDH = "mdh"


PARALLEL_TOLERANCE_RAD = 1e-9
"""`alpha` this close to 0 or ±π makes an `mdh` link's axis parallel to the previous one (round-off of a
document given in degrees: 180° · π/180 is exact to 1e-16 rad)."""


NEARLY_PARALLEL_RAD = math.radians(5.0)
"""How far from 0 or ±180° a link's `alpha` may be and still carry a given `beta`: the document of a calibrated
version (`GET /v1/robots/{id}/structure?version=n`) has the identified twist, a fraction of a degree off, and
must read back as the same structure; a twist of 90° is no parallel pair."""


def _from_parallel(alpha: float) -> float:
    return min(abs(alpha), abs(abs(alpha) - math.pi))


def is_parallel(alpha: float) -> bool:
    """True when `alpha` (rad) is 0 or ±π: consecutive joint axes are parallel."""
    return _from_parallel(alpha) < PARALLEL_TOLERANCE_RAD


def is_nearly_parallel(alpha: float) -> bool:
    """True when `alpha` (rad) is within `NEARLY_PARALLEL_RAD` of 0 or ±π."""
    return _from_parallel(alpha) < NEARLY_PARALLEL_RAD


@dataclass(frozen=True)
class DHLink:
    """One link: nominal DH numbers (mm, rad), the joint's range (mm or rad; 0, 0 for a fixed link) and its
    convention. `beta` is present (a parameter, nominal `beta`) exactly for `mdh` links with parallel axes."""

    joint: JointType
    theta: float
    d: float
    a: float
    alpha: float
    joint_min: float
    joint_max: float
    convention: Convention = Convention.DH
    beta: float = 0.0
    beta_given: bool = False
    """The link's document gave `beta` (any convention; accepted where `alpha` is near 0 or ±180°)."""

    @property
    def has_beta(self) -> bool:
        """`mdh` links with exactly parallel axes always; any link whose document gave `beta`, where its axes
        are nearly parallel (a calibrated document's `alpha` is a fraction of a degree off its nominal 0)."""
        if self.beta_given:
            return is_nearly_parallel(self.alpha)
        return self.convention is Convention.MDH and is_parallel(self.alpha)

    @property
    def fields(self) -> tuple[str, ...]:
        return DH_FIELDS + (("beta",) if self.has_beta else ())

    @property
    def n_params(self) -> int:
        return len(self.fields)

    @property
    def token(self) -> tuple[str, str, bool]:
        """What this link contributes to a structure key: convention, joint type, Hayati parameter."""
        return (self.convention.value, self.joint.value, self.has_beta)


# Order of a link's parameters in the parameter vector (spec: theta, d, a, alpha, then beta if any).
DH_FIELDS: tuple[str, ...] = ("theta", "d", "a", "alpha")
FIELD_KINDS: dict[str, Kind] = {
    "theta": Kind.ANGLE,
    "d": Kind.LENGTH,
    "a": Kind.LENGTH,
    "alpha": Kind.ANGLE,
    "beta": Kind.ANGLE,
}
DH_KINDS: tuple[Kind, ...] = tuple(FIELD_KINDS[f] for f in DH_FIELDS)


def dh_parameter_specs(
    links: tuple[DHLink, ...], length_scale: float, angle_scale: float, group: str = "carriage", first: int = 1
) -> list[ParameterSpec]:
    """The links' parameters, named `link{i}.{field}` from i = `first` (links are numbered across stages)."""
    specs = []
    for i, link in enumerate(links, start=first):
        for field in link.fields:
            kind = FIELD_KINDS[field]
            specs.append(
                ParameterSpec(
                    name=f"link{i}.{field}",
                    group=group,
                    kind=kind,
                    nominal=float(getattr(link, field)),
                    scale=length_scale if kind is Kind.LENGTH else angle_scale,
                )
            )
    return specs


def dh_transform(theta: Sym, d: Sym, a: Sym, alpha: Sym, beta: Sym | None = None) -> Sym:
    rz = homogeneous(rot_z(theta), ca.vertcat(0, 0, 0))
    rotation = rot_x(alpha) if beta is None else rot_x(alpha) @ rot_y(beta)
    tz_tx_rx = homogeneous(rotation, ca.vertcat(a, 0, d))
    # Tz(d)·Tx(a)·Rx(alpha)[·Ry(beta)] is a pure translation (a, 0, d) followed by the rotation.
    return rz @ tz_tx_rx


def mdh_transform(theta: Sym, d: Sym, a: Sym, alpha: Sym, beta: Sym | None = None) -> Sym:
    rotation = rot_x(alpha) if beta is None else rot_x(alpha) @ rot_y(beta)
    # Rx(α)·Ry(β)·Tx(a) = (R, R·(a, 0, 0)); then Rz(θ)·Tz(d) = (Rz, (0, 0, d)).
    first = homogeneous(rotation, rotation @ ca.vertcat(a, 0, 0))
    second = homogeneous(rot_z(theta), ca.vertcat(0, 0, d))
    return first @ second


def joint_link_values(
    links: tuple[DHLink, ...], q: Sym, params: Sym
) -> Iterator[tuple[DHLink, Sym, Sym, Sym, Sym, Sym | None]]:
    """Each link with its θ, d, a, α and β (None where it has none) from the links' parameters (in order), its
    joint value `q` added to θ (revolute) or d (prismatic): what every walk down the chain starts from."""
    at = 0
    k = 0
    for link in links:
        theta, d, a, alpha = (params[at + j] for j in range(4))
        beta = params[at + 4] if link.has_beta else None
        at += link.n_params
        if link.joint is JointType.REVOLUTE:
            theta = theta + q[k]
        elif link.joint is JointType.PRISMATIC:
            d = d + q[k]
        k += link.joint.moves
        yield link, theta, d, a, alpha, beta


def chain_transform(links: tuple[DHLink, ...], q: Sym, params: Sym) -> Sym:
    """Transform {0} -> {n} for the moving links' joint values `q` and the links' parameters (in order)."""
    if not links:
        return ca.SX.eye(4) if isinstance(q, ca.SX) else ca.MX.eye(4)
    t = None
    for link, theta, d, a, alpha, beta in joint_link_values(links, q, params):
        if link.convention is Convention.DH:
            a_i = dh_transform(theta, d, a, alpha, beta)
        else:
            a_i = mdh_transform(theta, d, a, alpha, beta)
        t = a_i if t is None else t @ a_i
    assert t is not None
    return t
