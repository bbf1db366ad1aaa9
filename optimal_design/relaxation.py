"""The continuous relaxation: weights 0 ≤ wᵢ ≤ 1 with Σwᵢ = K, and a bound no K-subset can beat.

Every criterion here is concave in w (D, A, E, I) or quasi-convex (condition),
so any feasible w with a (super)gradient, or any dual matrix, gives a valid
bound over *all* candidates, however w was found:

- D, A, I: `f(w') ≤ f(w) + gᵀ(w' − w)`; over the capped simplex the right side is
  largest for the K largest gᵢ (the Frank–Wolfe gap). w comes from a capped
  multiplicative algorithm (Titterington / Yu updates, rescaled onto the capped
  simplex), which needs one P × P inverse per iteration and no cone solver.
- E: `λ_min(M) ≤ tr(Z M)` for every density matrix Z, so the K largest
  `tr(Z Fᵢ)` bound λ_min of any K-subset. Condition: with Z₁, Z₂ the same for
  λ_min and λ_max, `λ_max/λ_min ≥ tr(Z₂M)/tr(Z₁M)`, minimised over K-subsets
  exactly (bisection on the ratio, K smallest terms). Z, Z₁, Z₂ are the dual
  matrices of the compressed SDPs that Clarabel solves on a screened set of
  candidates (`sdp`); the bound is reported only when Clarabel says solved.

Why not Clarabel for D, A and I too: their cones are 2P × 2P (108 × 108 here),
whose scaling block is a dense 5886 × 5886 matrix in every interior-point
iteration: ~30-100 s per solve measured on this machine, against seconds for
the first-order route with a certificate that is just as rigorous.

Scaling: the information matrices span eight orders of magnitude (the weakest
identifiable directions). λ_min only sees the weak end and λ_max the strong
end, so the SDPs are posed on those subspaces alone (orthonormal bases from
the D relaxation's information), each scaled by its own typical eigenvalue:
the cones see an O(1) spectrum and are a few dozen entries instead of 1 485.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.engine import cancellation
from optimal_design.criteria import (
    D_OPTIMAL,
    DesignCriterion,
    SmoothCriterion,
    SpectralCriterion,
    criterion_of,
    smooth,
    spectral,
    top_sum,
)
from optimal_design.information import CandidateInformation

MAX_ITERATIONS = 3000
TIME_LIMIT_S = 40.0
CHECK_EVERY = 25
"""Iterations on the working set between two passes over every candidate (the pass that certifies)."""
POWER_MIN = 0.5
"""The multiplicative update's exponent (SmoothCriterion.power) is halved on any drop of the objective, down to
this."""
INITIAL_SET = 1000
"""Beyond this many candidates the iterations start on the ones with the largest uniform-design variance."""
PRUNE = 1e-7
"""Weights below this leave the working set (they change log det by < 1e-5); a later full pass can bring them back."""
SCREENED = 240
"""Candidates in the first SDP round (column generation adds those the dual bound picks)."""
SUBSPACE_RATIO = 300.0
"""The first compressed SDP keeps the directions within this factor of the weakest (strongest) eigenvalue of the D
relaxation's information, at most SUBSPACE_START of them; at K = 30 of 2 000 that is 15 of 54 at each end."""
SUBSPACE_START = 10
"""At most this many directions at each end in the first round: Clarabel's time per iteration grows like the
cube of the cone's entries (q(q+1)/2), 13 ms at 15 directions and 110 ms at 36, while the bundle rounds below
find the directions that matter anyway."""
BUNDLE_GROW = 6
"""Weakest eigenvectors of each round's relaxed design added to the next round's weak basis (BUNDLE_GROW_STRONG
strongest to the strong one): λ_min's relaxed optimum lives where the D relaxation is not weakest, so the basis
must move with the relaxed design."""
BUNDLE_GROW_STRONG = 2
BUNDLE_KEEP = 1e-3
"""The next basis keeps the range of this round's dual matrix (its eigenvectors above this fraction of its
largest eigenvalue): the bound of the next round can then only use directions at least as good."""
BUNDLE_ROUNDS = 16
BUNDLE_ROUNDS_LARGE = 24
LARGE = 5000
"""Beyond LARGE candidates the 240 screened ones are a smaller share of the set, so column generation needs more
rounds."""
BUNDLE_TOLERANCE = 2e-3
"""Rounds stop once two in a row tightened the bound by less than this (relative)."""
SOLVER_OPTIONS: dict[str, float] = {"tol_gap_rel": 1e-5, "tol_gap_abs": 1e-7, "tol_feas": 1e-6}
"""Looser than Clarabel's 1e-8 defaults: 15 % fewer iterations, bounds equal to 6 digits at K = 30 of 2 000. The
bound's validity does not depend on the solver's accuracy: it is recomputed from the (PSD-projected) duals."""
REGULARISED: dict[str, float] = {
    "tol_gap_rel": 1e-4,
    "tol_gap_abs": 1e-6,
    "tol_feas": 1e-5,
    "static_regularization_constant": 1e-7,
}
SOLVER_ATTEMPTS: tuple[dict[str, float], ...] = (REGULARISED, SOLVER_OPTIONS)
"""Each round is solved looser and more regularised first, and retried with SOLVER_OPTIONS if that fails (with
SOLVER_OPTIONS alone a round failed on this machine's Clarabel at K = 30 of 2 000 and of 20 000, which ended
column generation early). The bounds stay valid either way (recomputed from the duals)."""


@dataclass(frozen=True)
class Relaxation:
    weights: Array
    bound: float | None
    """Upper bound on the utility (criteria.utility) of every K-subset; None when not certified."""
    method: str
    status: str
    iterations: int
    seconds: float
    note: str | None = None

    @property
    def certified(self) -> bool:
        return self.bound is not None


def capped(values: Array, total: float) -> Array:
    """min(1, c·values) with c chosen so the sum is `total` (values ≥ 0, enough of them positive).

    Exact: with the t largest values capped at 1, c = (total − t) / (sum of the others), and the right t is the
    first for which c leaves the (t+1)-th largest at most 1 and the t-th at least 1. One sort instead of a
    200-step bisection: 0.04 ms instead of 0.29 ms on 150 weights, which the multiplicative iterations call
    twice per iteration (a quarter of a branch-and-bound leaf's time). The bisection remains for the degenerate
    case (fewer than `total` positive values)."""
    v = np.asarray(values, dtype=float)
    s = np.sort(v)[::-1]
    rest = np.concatenate([np.cumsum(s[::-1])[::-1], [0.0]])  # rest[t] = sum of all but the t largest
    t = np.arange(s.size + 1)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        c = (total - t) / rest
        ok = (rest > 0) & (t <= total) & (c * np.append(s, 0.0) <= 1.0) & (np.insert(s, 0, np.inf) * c >= 1.0)
    if ok.any():
        return np.asarray(np.minimum(1.0, c[int(np.argmax(ok))] * v), dtype=float)
    return _capped_bisection(v, total)


def _capped_bisection(values: Array, total: float) -> Array:
    lo, hi = 0.0, 1.0
    while np.minimum(1.0, hi * values).sum() < total:
        hi *= 2.0
        if hi > 1e300:
            break
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.minimum(1.0, mid * values).sum() < total:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    return np.minimum(1.0, hi * values)


def first_order(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    count: int,
    base: Array,
    *,
    start: Array | None = None,
) -> Relaxation:
    """Capped multiplicative algorithm with its Frank–Wolfe certificate (D, A, I), on a working set.

    Most candidates' weights collapse within a few iterations (at K = 30 of 2 000 about 60 stay above 0.01), so
    the iterations run on a working set (the current support and the candidates with the largest gradient) and
    every `CHECK_EVERY` iterations one pass over all candidates computes the gradient, the certificate and the
    next working set. The certificate needs only a feasible w and the gradient at w over every candidate, so
    restricting the iterations costs no validity. Measured at K = 30: M = 2 000 went from 248 full iterations
    (1.1 s) to ~0.2 s, M = 20 000 from 446 full iterations that hit the 40 s limit to ~1 s.
    `start` (weights of a nearby problem, e.g. the previous K of a scan) warm-starts the iterations. Each
    iteration works on the working set's information blocks flattened (`_Grams`): two matrix-vector products.
    """
    # Long on purpose: one algorithm (multiplicative updates, working set, certificate) whose loop state every
    # step shares.
    started = time.perf_counter()
    crit = smooth(criterion)
    n = info.size
    power = crit.power
    w, active = _initial(info, crit, count, base, start)
    bound, f, it, since = np.inf, -np.inf, 0, CHECK_EVERY
    grams = _Grams(info, active)
    while it < MAX_ITERATIONS:
        cancellation.check()  # a design whose client left stops at its next iteration
        it += 1
        m = base + grams.information(w[active])
        previous = f
        inv = np.linalg.inv(m)
        f = crit.objective(info, m, inv)
        ga = grams.quadratic(crit.derivative(info, inv))
        # Only a multiplicative step can overshoot: after a pass that moved the working set (and re-projected
        # the weights) f may differ from the previous one by rounding alone, which halved the exponent at the
        # second iteration of every D relaxation (172 iterations at K = 30 of 2 000 instead of 92).
        if since > 0 and f < previous - 1e-12 * abs(previous) and power > POWER_MIN:
            power = max(POWER_MIN, power / 2)  # an overshoot: the update exponent was too bold for this problem
        restricted = f + top_sum(ga, count) - float(ga @ w[active])
        if since >= CHECK_EVERY or restricted - f <= crit.tolerance(f):
            since = 0
            g = info.quadratic(crit.derivative(info, inv))
            bound = min(bound, f + top_sum(g, count) - float(g @ w))
            if bound - f <= crit.tolerance(f) or time.perf_counter() - started > TIME_LIMIT_S:
                break
            # next working set: the support and the 3K candidates the linearisation likes most
            top = np.argpartition(-g, min(3 * count, n - 1))[: 3 * count]
            entering = np.setdiff1d(top, np.flatnonzero(w > PRUNE))
            w[entering] = np.maximum(w[entering], 1e-3)  # multiplicative updates cannot grow a zero weight
            active = np.union1d(np.flatnonzero(w > PRUNE), top)
            grams = grams.moved(active)
            w = _on(active, capped(w[active], count), n)
            continue
        since += 1
        new = capped(w[active] * np.maximum(ga, 0.0) ** power, count)
        keep = new > PRUNE
        active = active[keep]
        grams = grams.kept(keep)
        w = _on(active, capped(new[keep], count), n)
    return Relaxation(
        weights=w,
        bound=float(bound),
        method="capped multiplicative algorithm on a working set, Frank–Wolfe gap certificate over all candidates",
        status="optimal" if bound - f <= crit.tolerance(f) else "gap open",
        iterations=it,
        seconds=time.perf_counter() - started,
    )


def _initial(
    info: CandidateInformation, crit: SmoothCriterion, count: int, base: Array, start: Array | None
) -> tuple[Array, NDArray[Any]]:
    """The first weights and working set of `first_order`."""
    n = info.size
    if start is not None and start.shape == (n,) and float(np.sum(start)) > 0:
        # The start's support and the 3K candidates its gradient likes most: spreading a little weight over
        # every candidate instead kept all of them in the working set for the first ~10 iterations (a third of
        # a branch-and-bound leaf's time at M = 2 000).
        held = np.maximum(start, 0.0)
        _, g0 = crit.gradient(info, base + info.information(capped(held + 1e-3 * count / n, count)))
        top = np.argpartition(-g0, min(3 * count, n - 1))[: 3 * count]
        active = np.union1d(np.flatnonzero(held > PRUNE), top)
        return _on(active, capped(held[active] + 1e-3 * count / active.size, count), n), active
    if n > INITIAL_SET:
        _, g0 = crit.gradient(info, base + info.information(np.full(n, count / n)))
        active = np.sort(np.argsort(-g0)[: max(INITIAL_SET, 4 * count)])
        w = np.zeros(n)
        w[active] = count / active.size
        return w, active
    return np.full(n, count / n), np.arange(n)


class _Grams:
    """The working set's information blocks AᵢᵀAᵢ, flattened (a × P²): M(w) and tr(Q AᵢᵀAᵢ) are then one
    matrix-vector product each instead of products with the (a·r × P) rows, r times fewer operations (6 for full
    poses). The iterations only drop candidates: those stay in the table (`rows` says which are live) until
    fewer than half are, so dropping copies nothing; the table is rebuilt when the working set moves (every
    CHECK_EVERY iterations), reusing the blocks it already holds."""

    def __init__(
        self,
        info: CandidateInformation,
        active: NDArray[Any],
        flat: Array | None = None,
        rows: NDArray[Any] | None = None,
    ) -> None:
        self.info, self.active = info, active
        p = info.n_params
        blocks = info.blocks[active]
        self.flat = flat if flat is not None else (blocks.transpose(0, 2, 1) @ blocks).reshape(active.size, p * p)
        self.rows = rows if rows is not None else np.arange(active.size)

    def information(self, weights: Array) -> Array:
        p = self.info.n_params
        spread = np.zeros(self.flat.shape[0])
        spread[self.rows] = weights
        m = (spread @ self.flat).reshape(p, p)
        return np.asarray((m + m.T) / 2)

    def quadratic(self, q: Array) -> Array:
        return np.asarray((self.flat @ ((q + q.T) / 2).ravel())[self.rows])

    def kept(self, keep: NDArray[np.bool_]) -> _Grams:
        if keep.all():
            return self
        rows = self.rows[keep]
        if 2 * rows.size < self.flat.shape[0]:
            return _Grams(self.info, self.active[keep], self.flat[rows])
        return _Grams(self.info, self.active[keep], self.flat, rows)

    def moved(self, active: NDArray[Any]) -> _Grams:
        position = np.searchsorted(self.active, active).clip(max=max(self.active.size - 1, 0))
        held = self.active[position] == active if self.active.size else np.zeros(active.size, dtype=bool)
        flat = np.empty((active.size, self.flat.shape[1]))
        flat[held] = self.flat[self.rows[position[held]]]
        if (~held).any():
            flat[~held] = _Grams(self.info, active[~held]).flat
        return _Grams(self.info, active, flat)


NEWTON_GAP = 1e-4
"""Newton stops when the certificate is within this of log det: 100x tighter than GAP_D, in 4-6 iterations."""
NEWTON_ITERATIONS = 30
NEWTON_EDGE = 1e-3
"""Weights within this of 0 (1) whose gradient says they should stay there are moved onto the bound."""
ROOT_NEWTON_ITERATIONS = 10
"""The default path's polish gives up after this many (K = 30 of 2 000 converges in ~6; at K = 300, where many
weights sit at 1, Newton crawls: 30 iterations cost 0.4 s and did not converge)."""
NEWTON_COUNT = 64
"""Newton runs up to this K (root polish and branch-and-bound leaves): at K = 12-60 of 2 000 the polish converged
and cost 0.01-0.09 s; at K = 100 and 300 it did not converge within its iterations and cost 0.12 and 0.35 s for
nothing."""
NEWTON_FREE_MAX = 300
"""More free weights than this and Newton gives way to the multiplicative algorithm: its Hessian needs the
(6·free)² products of their rows (26 MB at 300); at K = 300 of 2 000 the polish cost 0.6 s and did not converge."""


def newton_d(
    info: CandidateInformation, count: int, base: Array, start: Array, *, iterations: int = NEWTON_ITERATIONS
) -> Relaxation | None:
    """The D relaxation from a nearby optimum (a branch-and-bound leaf's parent), by projected Newton steps;
    None when it does not reach NEWTON_GAP (the caller then runs `first_order`).

    The multiplicative algorithm converges sublinearly near the optimum: a leaf warm-started from its parent
    still took 70-90 iterations to the 0.01 gap, and left each leaf's bound ~0.01 above its optimum. Newton on
    the fractional weights (Hessian −tr(M⁻¹FᵢM⁻¹Fⱼ), the sum kept by an exact multiplier, each step projected
    onto the capped simplex and halved until log det rises) reaches a 1e-6 gap in 4-6 iterations from the
    parent's weights, at K = 30 of 2 000. The bound is the same Frank–Wolfe certificate over every candidate as
    `first_order`'s (valid for any weights with M ≻ 0), so how the weights were found does not matter."""
    # Long on purpose: one projected-Newton loop with its line search and certificate; every step shares its
    # state.
    started = time.perf_counter()
    n = info.size
    if count <= 0 or count >= n or start.shape != (n,):
        return None
    held = np.maximum(start, 0.0)
    if np.count_nonzero(held) < count:
        held = held + 1e-12
    w = capped(held, count)  # on the start's support: every later step works on a few hundred candidates

    def value(weights: Array) -> tuple[float, Array]:
        index = np.flatnonzero(weights > 0)
        m = base + info.information(weights[index], index)
        sign, logdet = np.linalg.slogdet(m)
        return (float(logdet) if sign > 0 else -np.inf), m

    f, m = value(w)
    if not np.isfinite(f):
        return None
    bound = np.inf
    # The start's support first: a nearby optimum's entrants are mostly there, and the pass over every
    # candidate that certifies the result brings in any that are not (100 leaves: 2.4-3.5 s instead of 2.9-3.6 s).
    support = np.flatnonzero(w > 0)
    pool: NDArray[Any] | None = support if support.size >= 2 * count else None
    for it in range(1, iterations + 1):
        cancellation.check()
        if pool is not None:
            # Between certificates the steps need the gradient on the support and the likely entrants only
            # (a pass over every candidate was 90 % of a leaf's time).
            _, partial = D_OPTIMAL.gradient(info, m, pool)
            if top_sum(partial, count) - float(partial @ w[pool]) > NEWTON_GAP:
                g = np.full(n, -np.inf)
                g[pool] = partial
            else:
                pool = None  # converged on the pool: certify over every candidate
        if pool is None:
            _, g = D_OPTIMAL.gradient(info, m)
            bound = min(bound, f + top_sum(g, count) - float(g @ w))
            pool = np.union1d(np.flatnonzero(w > 0), np.argpartition(-g, min(4 * count, n - 1))[: 4 * count])
        if bound - f <= NEWTON_GAP:
            return Relaxation(
                weights=w,
                bound=float(bound),
                method="projected Newton from a nearby optimum, Frank–Wolfe gap certificate over all candidates",
                status="optimal",
                iterations=it,
                seconds=time.perf_counter() - started,
            )
        found = _newton_step(info, count, w, g, m)
        if found is None:
            return None
        moved = _ascend(value, w, f, found, count)
        if moved is None:
            return None
        w, f, m = moved
    return None


def _ascend(
    value: Callable[[Array], tuple[float, Array]], w: Array, f: float, move: tuple[NDArray[Any], Array], count: int
) -> tuple[Array, float, Array] | None:
    """The step, projected onto the capped simplex and halved until log det rises: (weights, log det, M)."""
    work, step = move
    t = 1.0
    while t > 1e-6:
        trial = np.zeros(w.size)
        trial[work] = _project(w[work] + t * step[work], count)
        f_trial, m_trial = value(trial)
        if f_trial > f:
            return trial, f_trial, m_trial
        t *= 0.5
    return None


def _newton_step(
    info: CandidateInformation, count: int, w: Array, g: Array, m: Array
) -> tuple[NDArray[Any], Array] | None:
    """(the candidates a Newton step moves, the step over all candidates): weights at a bound that the gradient
    keeps there go onto it, the free ones take the Newton direction on Σw = K (an exact multiplier)."""
    n, r, p = info.size, info.rows, info.n_params
    level = float(np.partition(g, n - count)[n - count])  # the multiplier of Σw = K at the optimum
    work = np.union1d(np.flatnonzero(w > 0), np.argpartition(-g, min(2 * count, n - 1))[: 2 * count])
    gw, ww = g[work], w[work]
    to_zero = (ww <= NEWTON_EDGE) & (gw <= level)
    to_one = (ww >= 1 - NEWTON_EDGE) & (gw >= level)
    free = work[~(to_zero | to_one)]
    if free.size > NEWTON_FREE_MAX:
        return None
    step = np.zeros(n)
    step[work[to_zero]] = -w[work[to_zero]]
    step[work[to_one]] = 1 - w[work[to_one]]
    if free.size:
        rows = info.blocks[free].reshape(-1, p)
        near = rows @ np.linalg.inv(m) @ rows.T
        h = (near * near).reshape(free.size, r, free.size, r).sum(axis=(1, 3))
        h += 1e-10 * np.trace(h) / free.size * np.eye(free.size)
        try:
            a, b = np.linalg.solve(h, np.column_stack([g[free], np.ones(free.size)])).T
        except np.linalg.LinAlgError:
            return None
        mu = (a.sum() + step.sum()) / b.sum()  # the free weights absorb what the bounded ones moved
        step[free] = a - mu * b
    return work, step


def _project(v: Array, total: float) -> Array:
    """Euclidean projection onto {0 ≤ w ≤ 1, Σw = total}: clip(v − θ, 0, 1) with the sum piecewise linear and
    falling in θ, so θ interpolates between the two breakpoints (vᵢ − 1 or vᵢ) that bracket the total. Exact,
    one (2n × n) evaluation instead of a bisection's ~50 passes (15 % of a branch-and-bound leaf's time)."""
    points = np.unique(np.concatenate([v - 1.0, v]))
    sums = np.clip(v[None, :] - points[:, None], 0.0, 1.0).sum(axis=1)  # falling along the points
    k = int(np.searchsorted(-sums, -total, side="right")) - 1  # last point whose sum is at least the total
    if k < 0:
        theta = float(points[0])
    elif k >= points.size - 1 or sums[k] == sums[k + 1]:
        theta = float(points[min(k, points.size - 1)])
    else:
        theta = float(points[k] + (sums[k] - total) / (sums[k] - sums[k + 1]) * (points[k + 1] - points[k]))
    return np.asarray(np.clip(v - theta, 0.0, 1.0))


def _on(index: NDArray[Any], values: Array, n: int) -> Array:
    out = np.zeros(n)
    out[index] = values
    return out


def _subspace(m: Array, strong: bool) -> Array:
    """Orthonormal basis of the weakest (strongest) directions of m, within SUBSPACE_RATIO of the extreme."""
    ev, vec = np.linalg.eigh((m + m.T) / 2)
    if strong:
        q = int(np.sum(ev >= ev[-1] / SUBSPACE_RATIO))
        basis = vec[:, ::-1][:, : min(max(q, 2), SUBSPACE_START)]
    else:
        q = int(np.sum(ev <= ev[0] * SUBSPACE_RATIO))
        basis = vec[:, : min(max(q, 2), SUBSPACE_START)]
    return np.asarray(basis)


def _screen(info: CandidateInformation, weights: Array, weak: Array, size: int) -> Array:
    """Candidates the SDP is posed on: the D relaxation's strongest and those reaching furthest into the weak
    directions (in units of the D relaxation's own weak eigenvalues)."""
    reach = info.quadratic(weak @ weak.T)
    k = min(info.size, size // 2)
    return np.union1d(np.argsort(-weights)[:k], np.argsort(-reach)[:k])


def _bundle(basis: Array, dual: Array, extreme: Array) -> Array:
    """The next round's basis: the range of this round's dual matrix `dual` (q × q, on `basis`) and the relaxed
    design's extreme eigenvectors `extreme`, orthonormalised."""
    ev, vec = np.linalg.eigh((dual + dual.T) / 2)
    kept = basis @ vec[:, ev > BUNDLE_KEEP * max(float(ev[-1]), 1e-300)]
    q, r = np.linalg.qr(np.hstack([kept, extreme]))
    independent = np.abs(np.diag(r)) > 1e-10  # an extreme direction already in the kept range adds nothing
    return np.asarray(q[:, independent])


def sdp(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    count: int,
    base: Array,
    *,
    d_relaxation: Relaxation | None = None,
) -> Relaxation:
    """E or condition by Clarabel, compressed onto small weak (and strong) subspaces that move from round to
    round (a spectral bundle method), on screened candidates with column generation; the bound over all
    candidates comes from the dual matrices lifted back.

    Compression is what makes the cone small: λ_min(M) ≤ λ_min(VᵀMV) and λ_max(M) ≥ λ_max(UᵀMU) for orthonormal
    V, U, so the compressed problem is itself a relaxation; and whatever density matrices the solver returns,
    the bound is recomputed over every candidate from them (`_dual_bound`), so neither the compression, the
    screening nor the choice of basis can make it invalid, only looser. The dual matrix at the optimum has low
    rank (1-3 at K = 30 of 2 000), so each round's basis is the range of the previous dual plus the relaxed
    design's few weakest (strongest) eigenvectors: ~9 directions instead of a basis that only grows (15 -> 27 ->
    36, whose last round was 110 ms an interior-point iteration against 2 ms). Measured at K = 30 of 2 000: E bound
    0.00443 (three growing rounds, 3.1 s) -> 0.00434 (12 bundle rounds, 0.5 s), against 0.00429 for the
    uncompressed SDP on every candidate (146 s).
    """
    # Long on purpose: screening, the compressed solves and the certificate over all candidates: one chain of
    # results.
    started = time.perf_counter()
    crit = spectral(criterion)
    d = d_relaxation or first_order(info, D_OPTIMAL, count, base)
    ref = base + info.information(d.weights)
    weak = _subspace(ref, strong=False)
    strong = _subspace(ref, strong=True)
    index = _screen(info, d.weights, weak, SCREENED)
    best: tuple[Array, float] | None = None
    iterations, status, rounds, stalled = 0, "not run", 0, 0
    for _ in range(BUNDLE_ROUNDS_LARGE if info.size > LARGE else BUNDLE_ROUNDS):
        cancellation.check()
        solved = _compressed(info, crit, count, base, index=index, weak=weak, strong=strong)
        iterations += solved.iterations
        status = solved.status
        if solved.weights is None or solved.bound is None or solved.chosen is None or not solved.duals:
            break
        rounds += 1
        if best is not None and best[1] - solved.bound <= BUNDLE_TOLERANCE * abs(best[1]):
            stalled += 1
        else:
            stalled = 0
        if best is None or solved.bound < best[1]:
            best = (solved.weights, solved.bound)
        if stalled >= 2:
            break
        # Column generation: candidates the dual bound picks but the SDP did not see enter the next round; the
        # bases move to the dual's range plus the relaxed design's extreme directions (`_bundle`).
        index = np.union1d(index, solved.chosen)
        _, vec = np.linalg.eigh(base + info.information(solved.weights))
        weak = _bundle(weak, solved.duals[0], vec[:, :BUNDLE_GROW])
        if crit.strong_side:
            strong = _bundle(strong, solved.duals[1], vec[:, -BUNDLE_GROW_STRONG:])
    method = (
        "Clarabel SDP compressed onto moving weak/strong subspaces (spectral bundle), on screened candidates "
        "with column generation; dual bound over all candidates"
    )
    if best is None:
        return Relaxation(
            weights=d.weights,
            bound=None,
            method=method,
            status=status,
            iterations=iterations,
            seconds=time.perf_counter() - started,
            note=f"Clarabel did not solve the {crit.name.value} relaxation to optimality ({status}): "
            "no bound is reported; the design comes from rounding and exchange on the exact criterion",
        )
    return Relaxation(
        weights=best[0],
        bound=best[1],
        method=f"{method} ({rounds} rounds)",
        status="optimal",
        iterations=iterations,
        seconds=time.perf_counter() - started,
    )


@dataclass(frozen=True)
class _Round:
    """One compressed SDP: the weights over all candidates, the bound over all candidates, the candidates the
    bound picks, the dual matrices on the bases (weak side first), Clarabel's status and iterations."""

    weights: Array | None
    bound: float | None
    chosen: NDArray[Any] | None
    duals: list[Array]
    status: str
    iterations: int


def _svec(q: int) -> tuple[NDArray[Any], NDArray[Any], Array]:
    """(rows, columns, scale) of Clarabel's PSD triangle: the upper triangle column by column, off-diagonal
    entries times √2 (so that the inner product of two svec's is that of the matrices)."""
    r, c = np.triu_indices(q)
    order = np.lexsort((r, c))
    r, c = r[order], c[order]
    return r, c, np.where(r == c, 1.0, np.sqrt(2.0))


def _compressed(
    info: CandidateInformation,
    criterion: SpectralCriterion,
    count: int,
    base: Array,
    *,
    index: Array,
    weak: Array,
    strong: Array,
) -> _Round:
    """One compressed SDP (SpectralCriterion.homogeneous says which), solved by Clarabel directly.

    Variables x = [w (or u = τ·w), τ when homogeneous, s]; Clarabel minimises −s subject to b − Ax in its
    cones: Σw = K (Σu = Kτ); 0 ≤ w ≤ 1 (0 ≤ u ≤ τ, τ ≥ 0); VᵀM(w)V − s·I ⪰ 0; and I − UᵀM(u)U ⪰ 0 on the strong
    side. Each side is scaled by its own typical eigenvalue, so the cones see an O(1) spectrum. Written without
    cvxpy, whose compilation was ~10 % of a round and whose import (~0.9 s) every compute process would pay."""
    # Imported here, not with the module: a process that never solves a spectral design does not load the solver.
    import clarabel  # noqa: PLC0415
    from scipy import sparse  # noqa: PLC0415

    s = index.size
    homogeneous = criterion.homogeneous
    n_x = s + (2 if homogeneous else 1)
    bases = (weak, strong) if criterion.strong_side else (weak,)
    linear_a, linear_b, nonneg = _linear_rows(s, n_x, count, homogeneous)
    sides = [
        _cone_rows(info, base, count, index=index, basis=basis, on_strong=k == 1, homogeneous=homogeneous, n_x=n_x)
        for k, basis in enumerate(bases)
    ]
    a = sparse.vstack([linear_a, *(sparse.csr_matrix(rows) for rows, _ in sides)], format="csc")
    b = np.concatenate([linear_b, *(rhs for _, rhs in sides)])
    c = np.zeros(n_x)
    c[-1] = -1.0
    cones = [clarabel.ZeroConeT(1), clarabel.NonnegativeConeT(nonneg)]
    cones += [clarabel.PSDTriangleConeT(basis.shape[1]) for basis in bases]
    status, solution = _clarabel(sparse.csc_matrix((n_x, n_x)), c, a, b, cones)
    iterations = int(solution.iterations) if solution is not None else 0
    # "AlmostSolved" is usable too: the bound is recomputed from the PSD-projected duals, valid for any.
    if solution is None or status not in ("Solved", "AlmostSolved"):
        return _Round(None, None, None, [], status, iterations)
    x, z = np.asarray(solution.x, dtype=float), np.asarray(solution.z, dtype=float)
    raw = criterion.relaxed_weights(x[:s], float(x[s]) if homogeneous else 0.0)
    weights = np.zeros(info.size)
    weights[index] = np.clip(raw, 0.0, 1.0)
    duals = _psd_duals(z, bases, start=1 + nonneg)
    # Lift the duals back to the full parameter space: V Y Vᵀ is a density matrix there (up to its trace).
    zs = [basis @ dual @ basis.T for basis, dual in zip(bases, duals, strict=True)]
    bound, chosen = _dual_bound(info, criterion, count, base, zs)
    return _Round(weights, bound, chosen, duals, status, iterations)


def _clarabel(p: Any, c: Array, a: Any, b: Array, cones: list[Any]) -> tuple[str, Any]:
    """Clarabel's status and solution of min cᵀx (+ ½xᵀPx) s.t. b − Ax in `cones`, with each of
    SOLVER_ATTEMPTS' settings in turn until one solves (or almost)."""
    import clarabel  # noqa: PLC0415

    status, solution = "not run", None
    for options in SOLVER_ATTEMPTS:
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        for key, value in options.items():
            setattr(settings, key, value)
        solution = clarabel.DefaultSolver(p, c, a, b, cones, settings).solve()
        status = str(solution.status)
        if status in ("Solved", "AlmostSolved"):
            break
    return status, solution


def _psd_duals(z: Array, bases: tuple[Array, ...], *, start: int) -> list[Array]:
    """The dual matrices of the PSD cones (one per basis), read from Clarabel's scaled triangles from `start`."""
    duals, at = [], start
    for basis in bases:
        r, col, scale = _svec(basis.shape[1])
        y = np.zeros((basis.shape[1],) * 2)
        y[r, col] = y[col, r] = z[at : at + r.size] / scale
        duals.append(y)
        at += r.size
    return duals


def _linear_rows(s: int, n_x: int, count: int, homogeneous: bool) -> tuple[Any, Array, int]:
    """(A, b, the number of nonnegative rows) of Σw = K and 0 ≤ w ≤ 1, or of Σu = Kτ, 0 ≤ u ≤ τ and τ ≥ 0: the
    equality row first, then the nonnegative ones."""
    from scipy import sparse  # noqa: PLC0415

    total = np.zeros((1, n_x))
    total[0, :s] = 1.0
    eye = sparse.identity(s, format="csr")
    pad = sparse.csr_matrix((s, n_x - s))
    if not homogeneous:
        rows = [sparse.csr_matrix(total), sparse.hstack([eye, pad]), sparse.hstack([-eye, pad])]
        return sparse.vstack(rows, format="csr"), np.concatenate([[float(count)], np.ones(s), np.zeros(s)]), 2 * s
    total[0, s] = -float(count)
    tau = np.zeros((s, n_x - s))
    tau[:, 0] = -1.0  # u − τ ≤ 0
    last = np.zeros((1, n_x))
    last[0, s] = -1.0  # τ ≥ 0
    rows = [
        sparse.csr_matrix(total),
        sparse.hstack([eye, sparse.csr_matrix(tau)]),
        sparse.hstack([-eye, pad]),
        sparse.csr_matrix(last),
    ]
    return sparse.vstack(rows, format="csr"), np.zeros(2 * s + 2), 2 * s + 1


def _cone_rows(
    info: CandidateInformation,
    base: Array,
    count: int,
    *,
    index: Array,
    basis: Array,
    on_strong: bool,
    homogeneous: bool,
    n_x: int,
) -> tuple[Array, Array]:
    """(A, b) of one side's PSD cone in Clarabel's triangle (`_svec`): VᵀM(w)V − s·I on the weak side,
    I − UᵀM(u)U on the strong one, scaled by the side's typical eigenvalue (its extreme one over the screened
    candidates, per pose, times K)."""
    s = index.size
    whole = info.information(np.ones(s), index) + (0.0 if on_strong else base)
    ev = np.linalg.eigvalsh(basis.T @ whole @ basis)
    scale = max(float(ev[-1] if on_strong else ev[0]) / s * count, 1e-300)
    r, col, sc = _svec(basis.shape[1])
    rows = info.blocks[index] @ basis / np.sqrt(scale)
    f = np.einsum("mri,mrj->mij", rows, rows)[:, r, col] * sc  # (s, q(q+1)/2)
    fixed = (basis.T @ base @ basis / scale)[r, col] * sc
    eye = np.where(r == col, 1.0, 0.0)
    sign = 1.0 if on_strong else -1.0  # b − Ax: the strong side's information enters with −, the weak side's with +
    a = np.zeros((r.size, n_x))
    a[:, :s] = sign * f.T
    if homogeneous:
        a[:, s] = sign * fixed  # the measured poses scale with τ
        b = eye if on_strong else np.zeros(r.size)
    else:
        b = eye - fixed if on_strong else fixed
    if not on_strong:
        a[:, -1] = eye  # − s·I
    return a, b


def _psd(z: Array) -> Array:
    """The nearest PSD matrix: the bound needs Z ⪰ 0 exactly, and a solver's dual is PSD only to its tolerance."""
    ev, vec = np.linalg.eigh((z + z.T) / 2)
    return np.asarray((vec * np.clip(ev, 0.0, None)) @ vec.T)


def _dual_bound(
    info: CandidateInformation, criterion: SpectralCriterion, count: int, base: Array, zs: list[Array]
) -> tuple[float, NDArray[Any]]:
    """Bound on the utility of every K-subset from density matrices (see module docstring), and the K-subset
    that attains the bound's inner maximum (the candidates the next column-generation round must see)."""
    return criterion.dual_bound(info, count, base, [_psd(z) for z in zs])


def relax(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    count: int,
    base: Array,
    *,
    start: Array | None = None,
    d_relaxation: Relaxation | None = None,
) -> Relaxation:
    """The criterion's relaxation; E and condition start from the D relaxation (`d_relaxation` when the caller
    has it already)."""
    crit = criterion_of(criterion)
    if isinstance(crit, SpectralCriterion):
        return sdp(
            info, crit, count, base, d_relaxation=d_relaxation or relax(info, D_OPTIMAL, count, base, start=start)
        )
    relaxed = first_order(info, crit, count, base, start=start)
    if smooth(crit).newton and relaxed.bound is not None and count <= NEWTON_COUNT:
        # The multiplicative algorithm stops at a 0.01 gap; a few Newton steps from its weights close it (at
        # K = 30 of 2 000: 180.6636 -> 180.6549, ~6 iterations). Only the bound is taken: rounding and exchange
        # start from the same weights as before, so the design does not change.
        polished = newton_d(info, count, base, relaxed.weights, iterations=ROOT_NEWTON_ITERATIONS)
        if polished is not None and polished.bound is not None and polished.bound < relaxed.bound:
            relaxed = replace(
                relaxed,
                bound=polished.bound,
                method=relaxed.method + "; certificate tightened by projected Newton steps",
                status="optimal",
                iterations=relaxed.iterations + polished.iterations,
                seconds=relaxed.seconds + polished.seconds,
            )
    return relaxed
