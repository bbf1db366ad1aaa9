"""From weights to exactly K distinct poses, then Fedorov exchange on the exact criterion.

Rounding keeps the K largest weights. The exchange swaps one chosen pose for
one candidate whenever that improves the exact criterion, best swap first,
until no swap helps. Swap values come from low-rank updates (adding j, then
removing i): the determinant lemma and the Woodbury identity give log det,
trace(M'⁻¹) and trace(L M'⁻¹) from r × r positive definite systems for all
pairs at once (optimal_design.lowrank). E and the condition
number need the spectrum, so for them the pairs are evaluated on a pool of the
most promising candidates.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.engine import cancellation
from optimal_design.constraints import Spread
from optimal_design.criteria import (
    D_OPTIMAL,
    DesignCriterion,
    SmoothCriterion,
    SpectralCriterion,
    criterion_of,
    smooth,
    spectral,
)
from optimal_design.information import CandidateInformation
from optimal_design.lowrank import pair_terms, swap_terms

Index = NDArray[Any]

MAX_SWAPS = 400
POOL = 48
"""Candidates the spectral (E, condition) swaps are finally checked against, by _pool_score. Each costs K
eigenproblems of P × P per swap; 120 (and a small pool of 24) cost E and condition 1-2 s more at K = 30 of 2 000
for +0.02 / +0.005 efficiency."""
LOWRANK_POOL = 2500
"""Beyond this many candidates the low-rank swaps look at the ones that would add most (memory stays ~1 GB)."""
SMALL_POOL = 48
SMALL_SPECTRAL_POOL = 12
"""Each swap is first sought among this many most promising candidates; only when none of them improves is the
wide pool (every candidate up to LOWRANK_POOL, or POOL) evaluated, to confirm a local optimum or find the swap
the score missed. At K = 30 of 2 000 the A exchange from the greedy start went from 30 full evaluations of
59 100 pairs (5.7 s) to ~30 small and ~3 wide ones."""
UNIVERSE = 5000
LAZY_BATCH = 64
PAIR_CHUNK = 20_000
"""Pairs evaluated per batch of 2r × 2r systems (12 × 12 for full poses): ~25 MB of temporaries."""
IMPROVEMENT = 1e-10
BOUNDED_POOL = 200
"""From this many candidates on, the low-rank swaps are first bounded (SmoothCriterion.swap_bound) and only the
swaps the bound cannot rule out are evaluated: the bound costs one matrix product, the exact values an r × r
system per pair (for 48 candidates the bound saved nothing)."""


def round_weights(weights: Array, count: int, allowed: Index, spread: Spread | None = None) -> Array:
    """The K largest weights among the allowed candidates, skipping those closer than `spread` to one taken."""
    order = np.argsort(-np.where(allowed, weights, -np.inf), kind="stable")
    order = order[: int(allowed.sum())]
    if spread is None:
        return np.sort(order[:count])
    taken: list[int] = []
    for j in order:
        if spread.clear(int(j), taken):
            taken.append(int(j))
            if len(taken) == count:
                break
    if len(taken) < count:
        raise spread.too_tight(count, len(taken))
    return np.sort(np.array(taken))


def greedy(info: CandidateInformation, count: int, base: Array, allowed: Index, spread: Spread | None = None) -> Index:
    """Sequential D-greedy: add the candidate with the largest det increase (regularised until full rank).

    Lazy (Minoux): the gain log det(I + Aⱼ M⁻¹ Aⱼᵀ) of a candidate can only shrink as poses are added (M grows,
    M⁻¹ shrinks), so last step's gains bound this step's, and only the candidates whose stale gain beats the best
    fresh one are re-evaluated. Same choices as evaluating everyone every step; at M = 20 000 the 30 steps went
    from 30 passes over all candidates to ~1 pass and a few hundred re-evaluations."""
    p = info.n_params
    m = base.copy()
    chosen: list[int] = []
    reg = 1e-8 * max(np.trace(info.subset_information(np.flatnonzero(allowed))) / max(allowed.sum(), 1), 1e-300)
    free = allowed.copy()
    if spread is not None:
        free &= spread.clear_of_fixed()
    stale = np.full(info.size, np.inf)
    eye = np.eye(info.rows)[None]
    for _ in range(count):
        cancellation.check()  # one pose per step: a design whose client left stops here
        if not free.any():
            assert spread is not None
            raise spread.too_tight(count, len(chosen))
        inv = np.linalg.inv(m + reg * np.eye(p))
        fresh = np.zeros(info.size, dtype=bool)
        batch_size = LAZY_BATCH
        while True:
            pending = np.flatnonzero(free & ~fresh)
            if pending.size == 0:
                break
            unseen = pending[np.isinf(stale[pending])]
            if unseen.size:
                batch = unseen
            else:
                k = min(batch_size, pending.size)
                batch = pending[np.argpartition(-stale[pending], k - 1)[:k]]
                batch_size *= 2  # early steps re-evaluate most candidates: reach them in a few batches
            blocks = info.blocks[batch]
            # rows of one pose are coupled, so the gain is an r × r determinant. The (batch·r × P) @ (P × P)
            # product flattened: numpy runs a stacked (batch, r, P) @ (P, P) as one small product per candidate,
            # 4x slower (the greedy was a quarter of a D design's CPU time at K = 30 of 2 000).
            scaled = (blocks.reshape(-1, p) @ inv).reshape(blocks.shape)
            small = scaled @ blocks.transpose(0, 2, 1)
            stale[batch] = np.linalg.slogdet(eye + small)[1]
            fresh[batch] = True
            rest = free & ~fresh
            if not rest.any() or stale[free & fresh].max() >= stale[rest].max():
                break
        ready = np.flatnonzero(free & fresh)
        j = int(ready[int(np.argmax(stale[ready]))])
        chosen.append(j)
        free[j] = False
        if spread is not None:
            free &= spread.far_from(j)
        m = m + info.blocks[j].T @ info.blocks[j]
    return np.sort(np.array(chosen))


def _swap_values_lowrank(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    design: Index,
    base: Array,
    pool: Index,
    *,
    above: float | None = None,
) -> Array:
    """Utility after swapping design[a] for pool[b], all pairs (len(design), len(pool)), in chunks of pairs.

    With `above`, only the swaps that may exceed it are evaluated (the criterion's `swap_bound` says which; the
    others are −inf): the exchange asks only for improving swaps, and the D-efficiency floor only for those above
    it. At a local optimum that is a handful of the (K × M) swaps."""
    crit = smooth(criterion)
    m = base + info.subset_information(design)
    if above is not None and design.size and pool.size >= BOUNDED_POOL:
        return _bounded(info, crit, design, pool, m=m, above=above)
    inv = np.linalg.inv(m)
    step = max(1, PAIR_CHUNK // max(design.size, 1))
    parts = [_lowrank_chunk(info, crit, design, pool[lo : lo + step], m=m, inv=inv) for lo in range(0, pool.size, step)]
    return np.hstack(parts) if parts else np.empty((design.size, 0))


def _bounded(
    info: CandidateInformation, crit: SmoothCriterion, design: Index, pool: Index, *, m: Array, above: float
) -> Array:
    """The swaps whose bound exceeds `above` (less a margin for the bound's rounding) evaluated exactly, one
    system per pair; −inf for the others."""
    margin = 1e-9 * max(1.0, abs(above))
    rows, cols = np.nonzero(crit.swap_bound(info, design, pool, m=m, above=above) > above - margin)
    out = np.full((design.size, pool.size), -np.inf)
    inv = np.linalg.inv(m)
    a_out = info.blocks[design]
    for lo in range(0, rows.size, PAIR_CHUNK):
        a, j = rows[lo : lo + PAIR_CHUNK], cols[lo : lo + PAIR_CHUNK]
        entering, at = np.unique(j, return_inverse=True)
        out[a, j] = crit.swap_values(info, pair_terms(a_out, info.blocks[pool[entering]], (a, at), m, inv))
    return out


def _lowrank_chunk(
    info: CandidateInformation, criterion: SmoothCriterion, design: Index, pool: Index, *, m: Array, inv: NDArray[Any]
) -> Array:
    return criterion.swap_values(info, swap_terms(info.blocks[design], info.blocks[pool], m, inv))


RITZ_VECTORS = 8
"""Eigenvectors of M − FₐᵀFₐ (the design without pose a) per end of the spectrum for the Rayleigh–Ritz bounds
that rank the E and condition swaps before any is evaluated exactly."""
EXACT_BATCH = 32


def _swap_values_spectral(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    design: Index,
    base: Array,
    pool: Index,
    *,
    admissible: NDArray[np.bool_] | None = None,
) -> Array:
    """E or condition utility of the design with pose a swapped for pool candidate j, for the best swaps: exact
    where it can matter, −inf where a Rayleigh–Ritz bound proves the swap worse than one evaluated exactly (and
    where `admissible` is False), so the best swap (the argmax) is the exhaustive evaluation's.

    λ_min(M') ≤ λ_min(VᵀM'V) and λ_max(M') ≥ λ_max(UᵀM'U) for orthonormal V, U (Rayleigh–Ritz); with V and U
    the weakest and strongest eigenvectors of M − FₐᵀFₐ, each bound is an 8 × 8 problem instead of 54 × 54, and
    the utility's bound (λ_min's, or −√(λ_max/λ_min)'s) orders the exact evaluations, stopped once no bound
    left beats the best value found (measured at K = 30 of 2 000: 1.4 s of the E design's exchange before)."""
    crit = spectral(criterion)
    m = base + info.subset_information(design)
    f_out = np.asarray(info.blocks[design].transpose(0, 2, 1) @ info.blocks[design], dtype=float)
    f_in = np.asarray(info.blocks[pool].transpose(0, 2, 1) @ info.blocks[pool], dtype=float)
    without = m[None] - f_out
    ev, vec = np.linalg.eigh(without)
    k = min(RITZ_VECTORS, m.shape[0])
    weak = _ritz(ev[:, :k], vec[:, :, :k], info.blocks[pool], lowest=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = crit.ritz_bound(weak, lambda: _ritz(ev[:, -k:], vec[:, :, -k:], info.blocks[pool], lowest=False))
    if admissible is not None:
        bound = np.where(admissible, bound, -np.inf)
    out = np.full((design.size, pool.size), -np.inf)
    order = np.argsort(-bound, axis=None)
    best = -np.inf
    for lo in range(0, order.size, EXACT_BATCH):
        batch = order[lo : lo + EXACT_BATCH]
        a, j = np.unravel_index(batch, bound.shape)
        live = bound[a, j] > best
        if not live.any():
            break  # every swap left is bounded by one already evaluated
        a, j = a[live], j[live]
        exact = np.asarray(np.linalg.eigvalsh(without[a] + f_in[j]), dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            values = crit.spectral_values(exact)
        out[a, j] = values
        best = max(best, float(values.max()))
    return out


def _ritz(ev: Array, vec: Array, blocks: Array, *, lowest: bool) -> Array:
    """λ_min (or λ_max) of Vₐᵀ(M − FₐᵀFₐ + BⱼᵀBⱼ)Vₐ for every pose a and candidate j: an upper (lower) bound of
    the swapped design's λ_min (λ_max). `ev`, `vec`: the eigenpairs of M − FₐᵀFₐ whose vectors are Vₐ."""
    projected = np.einsum("jri,aik->ajrk", blocks, vec, optimize=True)  # Bⱼ Vₐ
    small = np.einsum("ajrk,ajrl->ajkl", projected, projected, optimize=True)
    small += np.eye(ev.shape[1])[None, None] * ev[:, None, :, None]
    values = np.linalg.eigvalsh(small)
    return np.asarray(values[..., 0] if lowest else values[..., -1])


def exchange(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    design: Index,
    *,
    base: Array,
    allowed: Index,
    weights: Array | None = None,
    spread: Spread | None = None,
    log_det_floor: float | None = None,
    wide: bool = True,
) -> tuple[Index, int]:
    """Improve `design` by best swaps until none helps; returns (design, swaps).

    With `log_det_floor`, only swaps that keep log det M at or above it are considered (the design must start
    there): how the E and condition designs keep a D-efficiency floor. `wide=False` never leaves the small pool.

    Each step looks for the best swap among the SMALL pool first, and falls back to the wide pool only when
    the small one has no improving swap; the design returned has no improving swap in the wide pool (every
    allowed candidate when there are at most LOWRANK_POOL, for D, A and I). With `spread`, only swaps that
    keep every pair of poses at least the minimum spread apart are considered."""
    # Long on purpose: one local search whose loop state (the factorisation, the candidates' values) every step
    # updates.
    crit = criterion_of(criterion)
    design = np.array(design)
    current = crit.utility(base + info.subset_information(design), info.task)
    swaps = 0
    on_spectrum = isinstance(crit, SpectralCriterion)
    small, wide_pool = (SMALL_SPECTRAL_POOL, POOL) if on_spectrum else (SMALL_POOL, LOWRANK_POOL)
    universe = allowed.copy()
    if universe.sum() > UNIVERSE:
        # Scoring every candidate at every swap cost 150 ms a swap at M = 20 000 (2.6 s of 4.9 s): score them all
        # once, then rescore only the UNIVERSE most promising at each swap.
        first = np.flatnonzero(allowed)
        score = _pool_score(info, crit, design, base, first, weights=weights)
        universe = np.zeros_like(allowed)
        universe[first[np.argsort(-score)[:UNIVERSE]]] = True
    stale: Index | None = None  # the last ranking, reused for the small pool (DesignCriterion.ranking_reuse)
    since_scored = 0
    where: dict[str, Any] = {"spread": spread, "log_det_floor": log_det_floor}

    while swaps < MAX_SWAPS:
        cancellation.check()
        where["current"] = current
        outside = universe.copy()
        outside[design] = False
        candidates = np.flatnonzero(outside)
        if candidates.size == 0:
            break
        found = None
        if stale is not None and since_scored < crit.ranking_reuse:
            # The ranking of a few swaps ago still points at good candidates: scoring every candidate again was
            # half of the D exchange's time. Only when it finds nothing is the ranking redone.
            found = _best_swap(info, crit, design, base, order=stale[outside[stale]], limits=(small,), **where)
        if found is None:
            order = candidates
            if candidates.size > small:
                score = _pool_score(info, crit, design, base, candidates, weights=weights)
                order = candidates[np.argsort(-score)]
            stale, since_scored = order, 0
            found = _best_swap(
                info, crit, design, base, order=order, limits=(small, wide_pool) if wide else (small,), **where
            )
        if found is None:
            break
        leaving = design[found[0]]
        design[found[0]] = found[1]
        swapped = crit.utility(base + info.subset_information(design), info.task)
        if not swapped > current:
            # The low-rank value said better, the design itself does not (a swap onto a numerically singular
            # design whose value was finite): undo it and stop here, at the last design that was better.
            design[found[0]] = leaving
            break
        swaps += 1
        since_scored += 1
        current = swapped
    return np.sort(design), swaps


def _best_swap(
    info: CandidateInformation,
    crit: DesignCriterion,
    design: Index,
    base: Array,
    *,
    order: Index,
    limits: tuple[int, ...],
    current: float,
    spread: Spread | None,
    log_det_floor: float | None,
) -> tuple[int, int] | None:
    """(position in the design, candidate) of the best improving swap among the first `limits[0]` candidates of
    `order`, then the first `limits[1]`, ...; None when none improves."""
    threshold = current + IMPROVEMENT * max(1.0, abs(current))
    for limit in limits:
        pool = order[:limit]
        if pool.size == 0:
            break
        # Which swaps are allowed at all, before their values: the spectral evaluation skips swaps that a
        # bound proves worse than an evaluated one, which must be an allowed one.
        admissible = np.ones((design.size, pool.size), dtype=bool)
        if spread is not None:
            admissible &= spread.swap_mask(design, pool)
        if log_det_floor is not None:
            admissible &= (
                _swap_values_lowrank(info, D_OPTIMAL, design, base, pool, above=log_det_floor) >= log_det_floor
            )
        if isinstance(crit, SpectralCriterion):
            values = _swap_values_spectral(info, crit, design, base, pool, admissible=admissible)
        else:
            values = _swap_values_lowrank(info, crit, design, base, pool, above=threshold)
            values = np.where(admissible, values, -np.inf)
        a, b = np.unravel_index(int(np.argmax(values)), values.shape)
        if values[a, b] > threshold:
            return int(a), int(pool[b])
        if pool.size == order.size:
            break
    return None


def _pool_score(
    info: CandidateInformation,
    criterion: DesignCriterion,
    design: Index,
    base: Array,
    pool: Index,
    *,
    weights: Array | None,
) -> Array:
    """How much each outside candidate would add (DesignCriterion.pool_gain), plus its relaxed weight."""
    gain = criterion.pool_gain(info, base + info.subset_information(design), pool)
    if weights is not None:
        gain = gain + weights[pool] * gain.max()
    return np.asarray(gain)
