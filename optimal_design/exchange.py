"""From weights to exactly K distinct poses, then Fedorov exchange on the exact criterion.

Rounding keeps the K largest weights. The exchange swaps one chosen pose for
one candidate whenever that improves the exact criterion, best swap first,
until no swap helps. Swap values come from low-rank updates: with
`U = [Aⱼᵀ, Aᵢᵀ]` (adding j, removing i), `M' = M + U C Uᵀ`, `C = diag(I, −I)`;
the determinant lemma and the Woodbury identity give log det, trace(M'⁻¹) and
trace(L M'⁻¹) from 2r × 2r systems for all pairs at once. E and the condition
number need the spectrum, so for them the pairs are evaluated on a pool of the
most promising candidates.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from models.kinematics import Array
from optimal_design.criteria import Criterion, utility
from optimal_design.information import CandidateInformation

Index = NDArray[Any]

MAX_SWAPS = 400
POOL = 150
LOWRANK_POOL = 2500
"""Beyond this many candidates the low-rank swaps look at the ones that would add most (memory stays ~1 GB)."""
IMPROVEMENT = 1e-10


def round_weights(weights: Array, count: int, allowed: Index) -> Array:
    order = np.argsort(-np.where(allowed, weights, -np.inf), kind="stable")
    return np.sort(order[:count])


def greedy(info: CandidateInformation, count: int, base: Array, allowed: Index) -> Index:
    """Sequential D-greedy: add the candidate with the largest det increase (regularised until full rank)."""
    p = info.n_params
    m = base.copy()
    chosen: list[int] = []
    reg = 1e-8 * max(np.trace(info.subset_information(np.flatnonzero(allowed))) / max(allowed.sum(), 1), 1e-300)
    free = allowed.copy()
    for _ in range(count):
        inv = np.linalg.inv(m + reg * np.eye(p))
        # log det(I + A M⁻¹ Aᵀ) for each candidate; rows of one pose are coupled, so use the r × r determinant.
        small = np.einsum("mri,ij,msj->mrs", info.blocks, inv, info.blocks, optimize=True)
        gain = np.linalg.slogdet(np.eye(info.rows)[None] + small)[1]
        gain[~free] = -np.inf
        j = int(np.argmax(gain))
        chosen.append(j)
        free[j] = False
        m = m + info.blocks[j].T @ info.blocks[j]
    return np.sort(np.array(chosen))


def _swap_values_lowrank(
    info: CandidateInformation, criterion: Criterion, design: Index, base: Array, pool: Index
) -> Array:
    """Utility after swapping design[a] for pool[b], all pairs (len(design), len(pool))."""
    m = base + info.subset_information(design)
    inv = np.linalg.inv(m)
    r = info.rows
    a_in = info.blocks[pool]  # (J, r, P)
    a_out = info.blocks[design]  # (I, r, P)
    jj = np.einsum("jri,ik,jsk->jrs", a_in, inv, a_in, optimize=True)
    ii = np.einsum("ari,ik,ask->ars", a_out, inv, a_out, optimize=True)
    ij = np.einsum("jri,ik,ask->ajrs", a_in, inv, a_out, optimize=True)  # (I, J, r, r)
    n_i, n_j = design.size, pool.size
    # S = C⁻¹ + Uᵀ M⁻¹ U with C⁻¹ = diag(I, −I)
    s = np.empty((n_i, n_j, 2 * r, 2 * r))
    s[:, :, :r, :r] = np.eye(r) + jj[None]
    s[:, :, r:, r:] = -np.eye(r) + ii[:, None]
    s[:, :, :r, r:] = ij
    s[:, :, r:, :r] = ij.transpose(0, 1, 3, 2)
    if criterion is Criterion.D:
        sign, logdet_s = np.linalg.slogdet(s)
        # det(M') = det(M) det(C) det(S), det(C) = (−1)^r
        value = np.linalg.slogdet(m)[1] + logdet_s
        value[sign * (-1) ** r <= 0] = -np.inf
        return value
    lm = np.eye(m.shape[0]) if criterion is Criterion.A else info.task
    q = inv @ lm @ inv
    # trace(L M'⁻¹) = trace(L M⁻¹) − trace(S⁻¹ Uᵀ Q U)
    qjj = np.einsum("jri,ik,jsk->jrs", a_in, q, a_in, optimize=True)
    qii = np.einsum("ari,ik,ask->ars", a_out, q, a_out, optimize=True)
    qij = np.einsum("jri,ik,ask->ajrs", a_in, q, a_out, optimize=True)
    w = np.empty_like(s)
    w[:, :, :r, :r] = qjj[None]
    w[:, :, r:, r:] = qii[:, None]
    w[:, :, :r, r:] = qij
    w[:, :, r:, :r] = qij.transpose(0, 1, 3, 2)
    try:
        correction = np.einsum("abii->ab", np.linalg.solve(s, w))
    except np.linalg.LinAlgError:
        return np.full((n_i, n_j), -np.inf)
    return -(float(np.trace(lm @ inv)) - correction)


def _swap_values_spectral(
    info: CandidateInformation, criterion: Criterion, design: Index, base: Array, pool: Index
) -> Array:
    m = base + info.subset_information(design)
    f_in = np.einsum("jri,jrk->jik", info.blocks[pool], info.blocks[pool])
    f_out = np.einsum("ari,ark->aik", info.blocks[design], info.blocks[design])
    out = np.empty((design.size, pool.size))
    for a in range(design.size):
        ev = np.linalg.eigvalsh(m[None] - f_out[a][None] + f_in)
        with np.errstate(divide="ignore", invalid="ignore"):
            if criterion is Criterion.E:
                out[a] = ev[:, 0]
            else:
                out[a] = np.where(ev[:, 0] > 0, -np.sqrt(ev[:, -1] / ev[:, 0]), -np.inf)
    return out


def exchange(
    info: CandidateInformation,
    criterion: Criterion,
    design: Index,
    *,
    base: Array,
    allowed: Index,
    weights: Array | None = None,
) -> tuple[Index, int]:
    """Improve `design` by best swaps until none helps; returns (design, swaps)."""
    design = np.array(design)
    current = utility(criterion, base + info.subset_information(design), info.task)
    swaps = 0
    spectral = criterion in (Criterion.E, Criterion.CONDITION)
    for swaps in range(MAX_SWAPS):  # noqa: B007
        outside = allowed.copy()
        outside[design] = False
        pool = np.flatnonzero(outside)
        if pool.size == 0:  # every candidate is in the design (count = M): nothing to swap with
            break
        limit = POOL if spectral else LOWRANK_POOL
        if pool.size > limit:
            score = _pool_score(info, criterion, design, base, pool, weights=weights)
            pool = pool[np.argsort(-score)[:limit]]
        values = (_swap_values_spectral if spectral else _swap_values_lowrank)(info, criterion, design, base, pool)
        a, b = np.unravel_index(int(np.argmax(values)), values.shape)
        if not values[a, b] > current + IMPROVEMENT * max(1.0, abs(current)):
            break
        design[a] = pool[b]
        current = utility(criterion, base + info.subset_information(design), info.task)
    return np.sort(design), swaps


def _pool_score(
    info: CandidateInformation, criterion: Criterion, design: Index, base: Array, pool: Index, *, weights: Array | None
) -> Array:
    """How much each outside candidate would add: its variance function tr(M⁻¹AᵢᵀAᵢ) for the low-rank criteria,
    its reach along the design's weakest directions for E and condition (plus its relaxed weight)."""
    m = base + info.subset_information(design)
    if criterion in (Criterion.E, Criterion.CONDITION):
        ev, vec = np.linalg.eigh(m)
        weak = vec[:, :3] / np.sqrt(np.maximum(ev[:3], 1e-300))
        gain = np.sum((info.blocks[pool] @ weak) ** 2, axis=(1, 2))
    else:
        gain = np.einsum("mri,ij,mrj->m", info.blocks[pool], np.linalg.inv(m), info.blocks[pool], optimize=True)
    if weights is not None:
        gain = gain + weights[pool] * gain.max()
    return gain
