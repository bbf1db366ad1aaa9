"""The weighted, column-scaled identification Jacobian and what it can identify.

One source for identification and pose design: both call `scaled_jacobian`,
`analyse_identifiability`, and the rules below: the structural subset
(`structural_identifiability`), the minimum number of poses
(`minimum_poses`) and "the structural subset if the data support it, else
their own" (`identifiable_subset`).

Scaling. Rows are divided by the instrument noise (position σ in mm,
orientation σ in rad), columns multiplied by each parameter's scale (its
expected error). A singular value `s` of the result then means: moving the
parameters one "tolerance" along that direction changes the measurements by
`s` standard deviations; after a fit its standard deviation is `1/s`
tolerances.

Rank. Exact redundancies of the model (a rigid motion of all platform joints
equals a tool change, ...) give singular values at round-off level, about
1e-16 of the largest; real, merely weak directions sit many orders above.
The rank counts singular values above `RANK_RTOL · s_max`; `RANK_RTOL = 1e-9`
lies in that gap, independently of how many poses or how much noise (both
scale all singular values alike). The subset that is identified is chosen by
QR with column pivoting.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from models._types import Array
from models.description.parameters import ParameterTable
from models.description.robot import RobotDescription
from models.description.terms import MIN_PAYLOAD_SPREAD_KG, MIN_TEMPERATURE_SPAN_K, Conditions, make_conditions
from models.engine.runtime import Runtime, runtime_for
from models.errors import WrongShape
from models.kinematics import forward_kinematics
from models.measurement import MeasurementKind
from models.measurements import measurement
from models.noise import NoiseModel
from models.workspace import workspace_samples

RANK_RTOL = 1e-9
"""Singular values below this fraction of the largest count as zero (see module docstring)."""
REGAINED_RTOL = 1e-5
"""At a fitted geometry, a direction counts only above this fraction of the largest singular value (rich data,
σ per tolerance): a tool a fraction of a millimetre off the last axis (a simulated tool error) makes that axis'
parameters "identifiable" at 1e-9 yet determined to degrees; a reflector centimetres off it clears 1e-5."""
CONFOUNDING_REPORT = 4
"""How many identifiable partners to report for each unidentifiable parameter."""
STRUCTURAL_POSES = 60
STRUCTURAL_SEED = 20_090_101


def measurement_rows(kind: MeasurementKind | bool) -> int:
    """Equations per pose; `kind` may still be given as the older `position_only` flag."""
    return MeasurementKind.of(kind).rows


def scaled_jacobian(
    jacobians: Array,
    table: ParameterTable,
    noise: NoiseModel,
    *,
    kind: MeasurementKind | None = None,
    position_only: bool | None = None,
) -> Array:
    """Stack per-pose Jacobians (N, 6, P) into the weighted, column-scaled (N·rows, P) matrix.

    `kind` says what is measured (`position_only=True` is the older spelling of `kind=POSITION`).
    """
    if jacobians.ndim != 3 or jacobians.shape[1] != 6 or jacobians.shape[2] != len(table):
        raise WrongShape(
            f"expected Jacobians of shape (N, 6, {len(table)}), got {jacobians.shape}",
            field="jacobians",
            expected=[-1, 6, len(table)],
            got=list(jacobians.shape),
        )
    rows = measurement(kind or MeasurementKind.of(bool(position_only))).information(jacobians, noise)
    blocks = rows * table.scales[None, None, :]
    return np.asarray(blocks.reshape(-1, len(table)), dtype=float)


@dataclass(frozen=True)
class Confounding:
    name: str
    partners: tuple[tuple[str, float], ...]
    """(identifiable parameter, coefficient): the unidentifiable column equals Σ coefficient · partner column."""


@dataclass(frozen=True)
class Identifiability:
    names: tuple[str, ...]
    identifiable: tuple[int, ...]
    """Indices (table order) of the parameters the data determine."""
    unidentifiable: tuple[int, ...]
    rank: int
    singular_values: Array
    """Of the scaled Jacobian restricted to the candidate parameters, descending."""
    threshold: float
    confounding: tuple[Confounding, ...]
    missing: tuple[tuple[str, str], ...] = ()
    """(parameter, what to measure) for the model terms' parameters these conditions cannot determine
    (`condition_support`): reported unidentifiable whatever the rank says."""

    @property
    def identifiable_names(self) -> tuple[str, ...]:
        return tuple(self.names[i] for i in self.identifiable)

    @property
    def unidentifiable_names(self) -> tuple[str, ...]:
        return tuple(self.names[i] for i in self.unidentifiable)

    @property
    def condition_number(self) -> float:
        kept = self.singular_values[: self.rank]
        return float(kept[0] / kept[-1]) if self.rank else float("inf")


def analyse_identifiability(
    scaled: Array,
    table: ParameterTable,
    candidates: tuple[int, ...] | None = None,
    rtol: float = RANK_RTOL,
) -> Identifiability:
    """Which of `candidates` (default: all) the scaled Jacobian can identify, and what the rest are confounded with."""
    cand = tuple(range(len(table))) if candidates is None else tuple(candidates)
    sub = scaled[:, cand]
    s = np.linalg.svd(sub, compute_uv=False)
    threshold, rank = _rank(s, rtol)
    _, _, pivots = scipy.linalg.qr(sub, mode="economic", pivoting=True)
    chosen = sorted(cand[int(p)] for p in pivots[:rank])
    rest = sorted(set(cand) - set(chosen))
    confounding: list[Confounding] = []
    if rest and chosen:
        coef, *_ = np.linalg.lstsq(scaled[:, chosen], scaled[:, rest], rcond=None)
        for k, j in enumerate(rest):
            c = coef[:, k]
            order = np.argsort(-np.abs(c))[:CONFOUNDING_REPORT]
            keep = [
                (table.names[chosen[i]], float(c[i])) for i in order if abs(c[i]) > 1e-6 * max(1.0, np.abs(c).max())
            ]
            confounding.append(Confounding(table.names[j], tuple(keep)))
    return Identifiability(
        names=table.names,
        identifiable=tuple(chosen),
        unidentifiable=tuple(rest),
        rank=rank,
        singular_values=np.asarray(s, dtype=np.float64),
        threshold=threshold,
        confounding=tuple(confounding),
    )


def _rank(s: NDArray[np.floating[Any]], rtol: float) -> tuple[float, int]:
    """(threshold, rank) from singular values `s` (descending): those above `rtol` · s_max count."""
    threshold = float(s[0] * rtol) if s.size and s[0] > 0 else 0.0
    return threshold, int(np.sum(s > threshold)) if threshold > 0 else 0


def numerical_rank(scaled: Array, candidates: tuple[int, ...], rtol: float = RANK_RTOL) -> int:
    """The rank `analyse_identifiability` gives the scaled Jacobian's `candidates` columns, without choosing them."""
    return _rank(np.linalg.svd(scaled[:, list(candidates)], compute_uv=False), rtol)[1]


def structural_identifiability(
    desc: RobotDescription,
    candidates: tuple[int, ...],
    kind: MeasurementKind | bool,
    *,
    runtime: Runtime | None = None,
) -> Identifiability:
    """What rich data could identify on this robot: the analysis on many random poses of the nominal model.

    Exact redundancies are properties of the structure, so the subset chosen here is the one every campaign of
    this robot uses (when its data support it): two calibrations name the same parameters, instead of subsets
    that differ wherever noise breaks a tie between equivalent columns. QR with column pivoting keeps the
    strongest columns, so the chosen parametrisation is also the best conditioned (measured: choosing the
    tool over platform joints instead makes the covariance 250 times worse conditioned). Kept by the runtime.
    """
    rt = runtime_for(desc, runtime)
    kind = MeasurementKind.of(kind)

    def analyse() -> Identifiability:
        joints = workspace_samples(desc, STRUCTURAL_POSES, STRUCTURAL_SEED, runtime=rt)
        fk = forward_kinematics(desc, joints, jacobian=True, runtime=rt, conditions=structural_conditions(desc))
        scaled = scaled_jacobian(fk.jacobians, desc.parameters, NoiseModel(), kind=kind)
        return analyse_identifiability(scaled, desc.parameters, candidates)

    return rt.artefact("structural_subset", (desc, tuple(candidates), kind), analyse, capacity=64)


def structural_identifiability_at(
    desc: RobotDescription,
    theta: Array,
    candidates: tuple[int, ...],
    kind: MeasurementKind | bool,
    *,
    runtime: Runtime | None = None,
) -> Identifiability:
    """`structural_identifiability` at the parameters `theta` rather than the description's nominal ones (not
    kept: one per fit that needs it). A nominal geometry can be special where the real one is not: a tool on the
    last joint's axis (a URDF's `tool0`) hides that joint's offset and twist from position measurements, which a
    reflector a few centimetres off that axis sees."""
    rt = runtime_for(desc, runtime)
    kind = MeasurementKind.of(kind)
    joints = workspace_samples(desc, STRUCTURAL_POSES, STRUCTURAL_SEED, runtime=rt)
    fk = forward_kinematics(desc, joints, theta, jacobian=True, runtime=rt, conditions=structural_conditions(desc))
    scaled = scaled_jacobian(fk.jacobians, desc.parameters, NoiseModel(), kind=kind)
    return analyse_identifiability(scaled, desc.parameters, candidates, rtol=REGAINED_RTOL)


def structural_conditions(desc: RobotDescription, n: int = STRUCTURAL_POSES) -> Conditions | None:
    """Conditions that make every term visible (temperatures over T_ref ± 8 K, payloads of 0 and 40 kg with an
    offset centre of gravity): rich data for the terms, as the random poses are for the geometry."""
    if not desc.terms.any:
        return None
    rng = np.random.default_rng(STRUCTURAL_SEED)
    t_ref = desc.terms.reference_temperature_c
    return make_conditions(
        n,
        temperature_c=t_ref + rng.permutation(np.linspace(-8.0, 8.0, n)),
        payload_kg=np.where(np.arange(n) % 2 == 0, 0.0, 40.0),
        payload_cog_mm=[30.0, -20.0, 100.0],
    )


def condition_support(desc: RobotDescription, conditions: Conditions | None) -> dict[int, str]:
    """The terms' parameters these conditions cannot determine, each with what to measure.

    At a single temperature κ only scales every leg (axis) reading, which encoders' own scale errors also do
    and no geometric parameter separates; the compliances need two payloads for the same reason (one load is
    a fixed shortening of each leg: its offset). So the rule is on the spread of the conditions, whatever rank
    a single temperature away from T_ref would give.
    """
    out: dict[int, str] = {}
    c = conditions or Conditions()
    span, spread = c.temperature_span_k, c.payload_spread_kg
    for name, i in desc.term_index.items():
        if name.startswith("thermal.") and span < MIN_TEMPERATURE_SPAN_K:
            out[i] = (
                f"{name} is not identifiable: the campaign's temperatures span {span:.1f} K; measure over at least "
                f"{MIN_TEMPERATURE_SPAN_K:.0f} K"
            )
        elif name.startswith("compliance.") and spread < MIN_PAYLOAD_SPREAD_KG:
            out[i] = (
                f"{name} is not identifiable: the campaign has one payload; measure with at least two payloads "
                f"(at least {MIN_PAYLOAD_SPREAD_KG:.0f} kg apart)"
            )
    return out


def without_unsupported(ident: Identifiability, unsupported: dict[int, str]) -> Identifiability:
    """`ident` with the parameters the conditions cannot determine moved to the unidentifiable ones."""
    if not unsupported:
        return ident
    keep = tuple(i for i in ident.identifiable if i not in unsupported)
    moved = sorted(set(ident.unidentifiable) | set(unsupported))
    return Identifiability(
        names=ident.names,
        identifiable=keep,
        unidentifiable=tuple(moved),
        rank=len(keep) if ident.rank == len(ident.identifiable) else min(ident.rank, len(keep)),
        singular_values=ident.singular_values,
        threshold=ident.threshold,
        confounding=tuple(c for c in ident.confounding if ident.names.index(c.name) not in unsupported),
        missing=tuple((ident.names[i], msg) for i, msg in sorted(unsupported.items())),
    )


def minimum_poses(
    desc: RobotDescription,
    candidates: tuple[int, ...],
    kind: MeasurementKind | bool,
    *,
    runtime: Runtime | None = None,
) -> tuple[int, int]:
    """(rank the structure allows for these parameters, fewest poses that can determine them and the noise)."""
    rank = structural_identifiability(desc, candidates, kind, runtime=runtime).rank
    return rank, poses_for(rank, kind)


def poses_for(rank: int, kind: MeasurementKind | bool) -> int:
    """The fewest poses that determine `rank` parameters and leave one degree of freedom for the noise: the one
    rule the identification refuses by and pose design designs by."""
    return math.ceil((rank + 1) / measurement_rows(kind))


@dataclass(frozen=True)
class StructuralSupport:
    """Whether a campaign's data determine the structural subset: the one rule identification and design share.

    Estimate the structural subset if the data support it, otherwise the data's own (smaller) subset,
    `analyse_identifiability(scaled, table, candidates)`.
    """

    structural: Identifiability
    data_rank: int
    """Rank of the data's scaled Jacobian on the structural subset."""

    @property
    def supported(self) -> bool:
        return self.data_rank == self.structural.rank


def structural_support(
    desc: RobotDescription,
    scaled: Array,
    candidates: tuple[int, ...],
    kind: MeasurementKind,
    *,
    runtime: Runtime | None = None,
) -> StructuralSupport:
    structural = structural_identifiability(desc, candidates, kind, runtime=runtime)
    # Only the rank: the pivoted QR that chooses a subset (and the confoundings) of analyse_identifiability
    # cost more than its SVD, for nothing here (2 000 candidate poses, 12 000 rows: ~10 ms of a design's 45 ms
    # information step).
    return StructuralSupport(structural, numerical_rank(scaled, structural.identifiable))
