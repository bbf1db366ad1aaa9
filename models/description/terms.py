"""Model terms beyond geometry: thermal expansion and leg compliance (issue 14), off by default.

- Thermal: a leg at temperature T is `(l_i + δl_i)(1 + κ_legs (T − T_ref))` long (commanded length plus its
  offset, expanded); a prismatic axis's travel scales by `(1 + κ_axes (T − T_ref))`. κ in 1/K inside,
  ppm/K at the boundary (`Kind.THERMAL`).
- Compliance (a robot with a hexapod: its legs): the payload's gravity wrench on the platform, mapped to leg
  tensions by the hexapod's statics `t = J⁻ᵀ w` (J the thesis Jacobian, eq. 48; `w` the force and its moment
  about the platform origin, in the hexapod's base frame {4}), lengthens leg i by `c_i · t_i` (c in mm/N inside,
  µm/N at the boundary,
  `Kind.COMPLIANCE`). A hanging load compresses legs that stand under the platform: they get shorter.
  A serial robot (no hexapod): each revolute joint turns by `k_j τ_j`, τ_j the payload's gravity torque about
  its axis at the commanded pose (first order: the deflection is evaluated where the joints are commanded),
  k in rad/(N·m) inside, µrad/(N·m) at the boundary (`Kind.JOINT_COMPLIANCE`).

The conditions of a record (temperature minus T_ref; the payload's gravity force in the world frame and its
centre of gravity in the tool frame) are an *input* of the Functions of a structure with terms, the
`conditions` vector below, never constants baked into a graph: one build serves every temperature and load.
The terms switched on are part of the structure key (they change the graphs); a description without terms
keeps its key, its Functions and its parameter list exactly as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array, first_nonfinite_record
from models.errors import InvalidInput, NonFiniteValue, WrongShape

GRAVITY_M_S2 = 9.80665
N_CONDITIONS = 7
"""The per-record conditions input: [ΔT (K), gravity force of the payload in the world frame (N, 3), its centre
of gravity in the tool frame (mm, 3)]."""
MIN_TEMPERATURE_SPAN_K = 4.0
"""A campaign identifies κ only when its temperatures span at least this much. At one temperature κ acts as
a scale of every leg (or axis) reading, which a real robot's encoders also have and no geometric parameter
separates; 4 K is where the expansion of a 460 mm steel leg (22 µm) reaches a tracker's σ (25 µm)."""
MIN_PAYLOAD_SPREAD_KG = 1.0
"""A campaign identifies the compliances only with at least two payloads this far apart."""
NOMINAL_KAPPA = 11.7e-6
"""Steel, 1/K."""
NOMINAL_LEG_COMPLIANCE = 1e-4
"""mm/N (0.1 µm/N: a leg of 10 N/µm stiffness)."""
NOMINAL_JOINT_COMPLIANCE = 2e-5
"""rad/(N·m) (20 µrad/(N·m): a joint of 5·10⁴ N·m/rad, an arm's gearbox)."""


@dataclass(frozen=True)
class ModelTerms:
    """Which terms a description models, and their settings (none of the settings is part of the structure)."""

    thermal: bool = False
    compliance: bool = False
    reference_temperature_c: float = 20.0
    """T_ref: the temperature at which the geometric parameters hold."""
    gravity: tuple[float, float, float] = (0.0, 0.0, -1.0)
    """Direction of gravity in the robot's world frame (the base transform's parent): world z up by default.
    After a calibration the world frame is the instrument's (the base is registered to it): a levelled tracker's
    z is up; an instrument that is not levelled needs its own direction here."""
    kappa_legs: float = NOMINAL_KAPPA
    kappa_axes: float = NOMINAL_KAPPA
    leg_compliance: float = NOMINAL_LEG_COMPLIANCE
    joint_compliance: float = NOMINAL_JOINT_COMPLIANCE

    @property
    def any(self) -> bool:
        return self.thermal or self.compliance

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for n, on in (("thermal", self.thermal), ("compliance", self.compliance)) if on)

    def gravity_unit(self) -> Array:
        g = np.asarray(self.gravity, dtype=float)
        norm = float(np.linalg.norm(g))
        if not (np.isfinite(norm) and norm > 0):
            raise InvalidInput("the gravity direction must be a non-zero vector", field="gravity")
        return g / norm


TERM_NAMES = ("thermal", "compliance")


@dataclass(frozen=True)
class Conditions:
    """What a campaign's records were measured under (internal units); any part may be absent."""

    temperature_c: Array | None = None
    """(N,) °C."""
    payload_kg: Array | None = None
    """(N,) kg."""
    payload_cog_mm: Array | None = None
    """(N, 3) centre of gravity in the tool (TCP) frame, mm."""

    def subset(self, index: ArrayLike) -> Conditions:
        idx = np.asarray(index)
        return Conditions(
            None if self.temperature_c is None else self.temperature_c[idx],
            None if self.payload_kg is None else self.payload_kg[idx],
            None if self.payload_cog_mm is None else self.payload_cog_mm[idx],
        )

    @property
    def temperature_span_k(self) -> float:
        t = self.temperature_c
        return 0.0 if t is None or t.size == 0 else float(np.max(t) - np.min(t))

    @property
    def payload_spread_kg(self) -> float:
        m = self.payload_kg
        return 0.0 if m is None or m.size == 0 else float(np.max(m) - np.min(m))


def make_conditions(
    n: int,
    temperature_c: ArrayLike | None = None,
    payload_kg: ArrayLike | None = None,
    payload_cog_mm: ArrayLike | None = None,
) -> Conditions:
    """Validated conditions of n records: a single number (or one cog) stands for every record."""
    temp = None if temperature_c is None else _per_record(temperature_c, n, "temperature_c")
    mass = None if payload_kg is None else _per_record(payload_kg, n, "payload.mass_kg")
    if mass is not None and np.any(mass < 0):
        raise InvalidInput("a payload's mass cannot be negative", field="payload.mass_kg", min=0.0)
    cog = None
    if payload_cog_mm is not None:
        c = np.array(payload_cog_mm, dtype=float)
        c = np.broadcast_to(c, (n, 3)).copy() if c.shape == (3,) else c
        if c.shape != (n, 3):
            raise WrongShape(
                f"expected a centre of gravity [x, y, z] (or one per record), got shape {c.shape}",
                field="payload.cog_mm",
                expected=[n, 3],
                got=list(c.shape),
            )
        _finite(c, "payload.cog_mm")
        cog = c
    if mass is not None and cog is None:
        cog = np.zeros((n, 3))
    return Conditions(temp, mass, cog)


def _per_record(values: ArrayLike, n: int, name: str) -> Array:
    v = np.array(values, dtype=float).reshape(-1)
    if v.size == 1:
        v = np.full(n, float(v[0]))
    if v.shape != (n,):
        raise WrongShape(f"expected one {name} or one per record ({n}), got {v.size}", field=name, expected=[n])
    _finite(v, name)
    return v


def _finite(a: Array, name: str) -> None:
    i = first_nonfinite_record(a)
    if i is not None:
        raise NonFiniteValue(f"record {i}: {name} is not a finite number", pose=i, field=name)


def condition_inputs(terms: ModelTerms, conditions: Conditions | None, n: int) -> Array:
    """The (n, 7) `conditions` input of a structure with terms; InvalidInput names what a term needs and the
    records lack (a temperature for the thermal term, a payload for the compliance term)."""
    out = np.zeros((n, N_CONDITIONS))
    c = conditions or Conditions()
    if terms.thermal:
        if c.temperature_c is None:
            raise InvalidInput(
                "the thermal term is on: every record needs its temperature_c (°C)", field="temperature_c"
            )
        out[:, 0] = c.temperature_c - terms.reference_temperature_c
    if terms.compliance:
        if c.payload_kg is None:
            raise InvalidInput(
                "the compliance term is on: the campaign (or every record) needs a payload {mass_kg, cog_mm}",
                field="payload",
            )
        out[:, 1:4] = (c.payload_kg * GRAVITY_M_S2)[:, None] * terms.gravity_unit()[None, :]
        assert c.payload_cog_mm is not None  # make_conditions pairs a mass with a cog
        out[:, 4:7] = c.payload_cog_mm
    return out
