"""The weighted, column-scaled identification Jacobian and what it can identify.

One source for identification and pose design: both call `scaled_jacobian`
and `analyse_identifiability`.

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

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from models.errors import WrongShape
from models.parameters import ParameterTable

Array = np.ndarray

RANK_RTOL = 1e-9
"""Singular values below this fraction of the largest count as zero (see module docstring)."""
CONFOUNDING_REPORT = 4
"""How many identifiable partners to report for each unidentifiable parameter."""


@dataclass(frozen=True)
class NoiseModel:
    """Instrument noise, internal units: σ position (mm) and σ orientation (rad)."""

    position_mm: float = 0.025
    orientation_rad: float = float(np.radians(0.01))


def measurement_rows(position_only: bool) -> int:
    return 3 if position_only else 6


def scaled_jacobian(jacobians: Array, table: ParameterTable, noise: NoiseModel, *, position_only: bool) -> Array:
    """Stack per-pose Jacobians (N, 6, P) into the weighted, column-scaled (N·rows, P) matrix."""
    if jacobians.ndim != 3 or jacobians.shape[1] != 6 or jacobians.shape[2] != len(table):
        raise WrongShape(f"expected Jacobians of shape (N, 6, {len(table)}), got {jacobians.shape}")
    rows = measurement_rows(position_only)
    weights = np.array([1 / noise.position_mm] * 3 + [1 / noise.orientation_rad] * 3)[:rows]
    blocks = jacobians[:, :rows, :] * weights[None, :, None] * table.scales[None, None, :]
    return blocks.reshape(-1, len(table))


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
    threshold = float(s[0] * rtol) if s.size and s[0] > 0 else 0.0
    rank = int(np.sum(s > threshold)) if threshold > 0 else 0
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
        singular_values=s,
        threshold=threshold,
        confounding=tuple(confounding),
    )
