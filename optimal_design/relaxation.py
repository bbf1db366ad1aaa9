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
  matrices of the SDP that cvxpy and Clarabel solve on a screened set of
  candidates; the bound is reported only when Clarabel says optimal.

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
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from models import cancellation
from models._types import Array
from optimal_design.criteria import (
    D_OPTIMAL,
    DesignCriterion,
    SpectralCriterion,
    criterion_of,
    smooth,
    spectral,
    top_sum,
)
from optimal_design.information import CandidateInformation

if TYPE_CHECKING:
    import cvxpy as cp

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
"""Candidates in the first SDP round (column generation adds more). E and condition spend their time on a larger weak
subspace instead: at K = 30 of 2 000, 400 rather than 240 tightened the E bound by 1 % and the condition bound by
0.7 % for 1.7x the SDP time."""
SUBSPACE_RATIO = 300.0
"""The compressed SDPs keep the directions within this factor of the weakest (strongest) eigenvalue of the D
relaxation's information; at K = 30 of 2 000 that is 15 of 54 at each end."""
SUBSPACE_MAX = 36
SUBSPACE_MISS = 0.05
"""A relaxed design's weakest (strongest) eigenvectors further than this from the basis enter it."""
SDP_ROUNDS = 3
SDP_ROUNDS_LARGE = 6
LARGE = 5000
"""Column-generation rounds beyond LARGE candidates: the 240 screened ones are a smaller share of the set, and the
bound keeps falling after round 3. At K = 30 of 20 000: E bound 0.00640 (3 rounds) -> 0.00603 (6), condition
6 746 -> 7 290 (efficiency 0.865 -> 0.920 and 0.860 -> 0.942), for ~3x the SDP time (one loaded run: E 26 s ->
59 s in all). At 2 000 the rounds stay 3, for the 5 s target (the bound still fell 8 % in the third)."""
SUBSPACE_GROW = 12
"""Weak directions added per round, every round (the strong side adds 2 when missed). λ_min's relaxed optimum
lives where the D relaxation is *not* weakest: the first round's E weights leave directions outside the
15-direction basis at λ ≈ 0.0017 while the compressed bound says 0.0056, so every round adds the relaxed design's
12 weakest eigenvectors. At K = 30 of 2 000: E bound 0.00519 (2 directions a round, grown only when missed, at
most 24) -> 0.00443 (15 -> 27 -> 36 directions), against 0.00429 for the uncompressed SDP on all 2 000 candidates
(146 s); condition bound 8 123 -> 8 806."""
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
"""Each round is solved looser and more regularised first, and retried with SOLVER_OPTIONS if that fails. With
SOLVER_OPTIONS alone the third round failed on this machine's Clarabel, at K = 30 of 2 000 (E) and of 20 000
(E), which ended column generation early (E efficiency 0.818 at 2 000, 0.687 at 20 000); as the fallback
of a failed first attempt it cost E 12 s instead of 5.7 s at 2 000 (a loaded run). The bounds agree to 4 digits
(E 0.0044327 against 0.0044325) and stay valid either way (recomputed from the duals)."""


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
    `start` (weights of a nearby problem, e.g. the previous K of a scan) warm-starts the iterations.
    """
    # Long on purpose: one algorithm (multiplicative updates, working set, certificate) whose loop state every
    # step shares.
    started = time.perf_counter()
    crit = smooth(criterion)
    n = info.size
    power = crit.power
    if start is not None and start.shape == (n,) and float(np.sum(start)) > 0:
        # The start's support and the 3K candidates its gradient likes most: spreading a little weight over
        # every candidate instead kept all of them in the working set for the first ~10 iterations (a third of
        # a branch-and-bound leaf's time at M = 2 000).
        held = np.maximum(start, 0.0)
        _, g0 = crit.gradient(info, base + info.information(capped(held + 1e-3 * count / n, count)))
        top = np.argpartition(-g0, min(3 * count, n - 1))[: 3 * count]
        active = np.union1d(np.flatnonzero(held > PRUNE), top)
        w = _on(active, capped(held[active] + 1e-3 * count / active.size, count), n)
    elif n > INITIAL_SET:
        _, g0 = crit.gradient(info, base + info.information(np.full(n, count / n)))
        active = np.sort(np.argsort(-g0)[: max(INITIAL_SET, 4 * count)])
        w = np.zeros(n)
        w[active] = count / active.size
    else:
        w = np.full(n, count / n)
        active = np.arange(n)
    bound, f, it, since = np.inf, -np.inf, 0, CHECK_EVERY
    while it < MAX_ITERATIONS:
        cancellation.check()  # a design whose client left stops at its next iteration
        it += 1
        m = base + info.information(w[active], active)
        previous = f
        f, ga = crit.gradient(info, m, active)
        if f < previous - 1e-12 * abs(previous) and power > POWER_MIN:
            power = max(POWER_MIN, power / 2)  # an overshoot: the update exponent was too bold for this problem
        restricted = f + top_sum(ga, count) - float(ga @ w[active])
        if since >= CHECK_EVERY or restricted - f <= crit.tolerance(f):
            since = 0
            _, g = crit.gradient(info, m)
            bound = min(bound, f + top_sum(g, count) - float(g @ w))
            if bound - f <= crit.tolerance(f) or time.perf_counter() - started > TIME_LIMIT_S:
                break
            # next working set: the support and the 3K candidates the linearisation likes most
            top = np.argpartition(-g, min(3 * count, n - 1))[: 3 * count]
            entering = np.setdiff1d(top, np.flatnonzero(w > PRUNE))
            w[entering] = np.maximum(w[entering], 1e-3)  # multiplicative updates cannot grow a zero weight
            active = np.union1d(np.flatnonzero(w > PRUNE), top)
            w = _on(active, capped(w[active], count), n)
            continue
        since += 1
        new = capped(w[active] * np.maximum(ga, 0.0) ** power, count)
        keep = new > PRUNE
        active = active[keep]
        w = _on(active, capped(new[keep], count), n)
    return Relaxation(
        weights=w,
        bound=float(bound),
        method="capped multiplicative algorithm on a working set, Frank–Wolfe gap certificate over all candidates",
        status="optimal" if bound - f <= crit.tolerance(f) else "gap open",
        iterations=it,
        seconds=time.perf_counter() - started,
    )


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
        basis = vec[:, ::-1][:, : min(max(q, 2), SUBSPACE_MAX)]
    else:
        q = int(np.sum(ev <= ev[0] * SUBSPACE_RATIO))
        basis = vec[:, : min(max(q, 2), SUBSPACE_MAX)]
    return np.asarray(basis)


def _screen(info: CandidateInformation, weights: Array, weak: Array, size: int) -> Array:
    """Candidates the SDP is posed on: the D relaxation's strongest and those reaching furthest into the weak
    directions (in units of the D relaxation's own weak eigenvalues)."""
    reach = info.quadratic(weak @ weak.T)
    k = min(info.size, size // 2)
    return np.union1d(np.argsort(-weights)[:k], np.argsort(-reach)[:k])


def sdp(
    info: CandidateInformation,
    criterion: str | DesignCriterion,
    count: int,
    base: Array,
    *,
    d_relaxation: Relaxation | None = None,
) -> Relaxation:
    """E or condition by cvxpy + Clarabel, compressed onto the weak (and strong) subspaces, on screened
    candidates; the bound over all candidates comes from the dual matrices lifted back.

    Compression is what makes the cone small: λ_min(M) ≤ λ_min(VᵀMV) and λ_max(M) ≥ λ_max(UᵀMU) for orthonormal
    V, U, so the compressed problem is itself a relaxation; and whatever density matrices the solver returns,
    the bound is recomputed over every candidate from them (`_dual_bound`), so neither the compression nor the
    screening can make it invalid, only looser. With 15 + 15 directions the cones are 120 + 120 entries instead
    of 2 × 1 485: Clarabel went from 3 s (E) and 10-19 s (condition) on 240 candidates to 0.3-0.5 s a round on
    ~400, and the larger screened set with column generation tightened both bounds at K = 30 of 2 000 (λ_min
    0.00528 -> 0.00519, condition number 7 786 -> 8 123).
    """
    # Long on purpose: screening, the compressed solve and the certificate over all candidates: one chain of
    # results.
    started = time.perf_counter()
    crit = spectral(criterion)
    d = d_relaxation or first_order(info, D_OPTIMAL, count, base)
    ref = base + info.information(d.weights)
    weak = _subspace(ref, strong=False)
    strong = _subspace(ref, strong=True)
    index = _screen(info, d.weights, weak, SCREENED)
    best: tuple[Array, float] | None = None
    iterations, status = 0, "not run"
    for _ in range(SDP_ROUNDS_LARGE if info.size > LARGE else SDP_ROUNDS):
        cancellation.check()
        weights, bound, chosen, status, its = _compressed(
            info, crit, count, base, index=index, weak=weak, strong=strong
        )
        iterations += its
        if weights is None or bound is None or chosen is None:
            break
        if best is None or bound < best[1]:
            best = (weights, bound)
        # Column generation: candidates the dual bound picks but the SDP did not see enter the next round, and
        # so do the relaxed design's weakest directions (every round, see SUBSPACE_GROW) and, when the strong
        # side counts, the strongest ones the basis missed.
        index = np.union1d(index, np.setdiff1d(chosen, index))
        _, vec = np.linalg.eigh(base + info.information(weights))
        missed_high = (
            crit.strong_side
            and np.linalg.norm(vec[:, -2:] - strong @ (strong.T @ vec[:, -2:]), axis=0).max() > SUBSPACE_MISS
        )
        if weak.shape[1] < SUBSPACE_MAX:
            weak = np.linalg.qr(np.hstack([weak, vec[:, :SUBSPACE_GROW]]))[0][:, :SUBSPACE_MAX]
        if missed_high and strong.shape[1] < SUBSPACE_MAX:
            strong = np.linalg.qr(np.hstack([strong, vec[:, -2:]]))[0][:, :SUBSPACE_MAX]
    method = (
        "cvxpy + Clarabel SDP compressed onto the weak/strong subspaces, on screened candidates with column "
        "generation; dual bound over all candidates"
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
        method=method,
        status="optimal",
        iterations=iterations,
        seconds=time.perf_counter() - started,
    )


def _compressed(
    info: CandidateInformation,
    criterion: SpectralCriterion,
    count: int,
    base: Array,
    *,
    index: Array,
    weak: Array,
    strong: Array,
) -> tuple[Array | None, float | None, NDArray[Any] | None, str, int]:
    """One compressed SDP: (weights over all candidates, bound over all candidates, the candidates the bound
    picks, status, iterations)."""
    # Long on purpose: the cvxpy problem written out in one place reads as the formulation it is.
    # Imported here, not with the module: cvxpy (and the scipy.stats it loads) is ~0.9 s of start-up that every
    # API, compute and job process would pay, most of which never solve a certified design.
    import cvxpy as cp  # noqa: PLC0415

    ref_low = float(np.linalg.eigvalsh(weak.T @ (base + info.information(np.ones(index.size), index)) @ weak)[0])
    scale_low = max(ref_low / index.size * count, 1e-300)

    def compress(on_strong: bool, homogeneous: bool) -> tuple[cp.Expression, int]:
        if on_strong:
            ref_high = float(np.linalg.eigvalsh(strong.T @ info.information(np.ones(index.size), index) @ strong)[-1])
            basis, scale = strong, max(ref_high / index.size * count, 1e-300)
        else:
            basis, scale = weak, scale_low
        rows = info.blocks[index] @ basis / np.sqrt(scale)
        q = basis.shape[1]
        f = np.einsum("mri,mrj->mij", rows, rows).reshape(index.size, q * q)
        flat = cp.reshape(f.T @ w, (q, q), order="C")
        fixed = basis.T @ base @ basis / scale
        # A homogenised problem (w stands for τ·w) scales the measured poses with τ too.
        return (flat + flat.T) / 2 + (tau * fixed if homogeneous else fixed), q

    tau = cp.Variable(nonneg=True)
    w = cp.Variable(index.size, nonneg=True)
    s = cp.Variable()
    problem, constraints = criterion.sdp_problem(cp, compress, count, w=w, tau=tau, s=s)
    status = "not run"
    for options in SOLVER_ATTEMPTS:
        try:
            with warnings.catch_warnings():
                # cvxpy warns on "optimal_inaccurate"; the bound does not rely on accuracy (see below)
                warnings.filterwarnings("ignore", message="Solution may be inaccurate", category=UserWarning)
                problem.solve(solver=cp.CLARABEL, **options)
            status = str(problem.status)
        except cp.error.SolverError as exc:
            status = f"solver error: {exc}"
        if status in ("optimal", "optimal_inaccurate"):
            break
    iterations = int(problem.solver_stats.num_iters or 0) if problem.solver_stats else 0
    duals = [c.dual_value for c in constraints]
    # "optimal_inaccurate" is usable too: the bound is recomputed from the PSD-projected duals, valid for any.
    if status not in ("optimal", "optimal_inaccurate") or any(dv is None for dv in duals) or w.value is None:
        return None, None, None, status, iterations
    scale = 0.0 if tau.value is None else float(np.asarray(tau.value))  # τ is no variable of a plain problem
    raw = criterion.relaxed_weights(np.asarray(w.value, dtype=float), scale)
    weights = np.zeros(info.size)
    weights[index] = np.clip(raw, 0.0, 1.0)
    # Lift the duals back to the full parameter space: V Y Vᵀ is a density matrix there (up to its trace).
    zs = [basis @ np.asarray(dual, dtype=float) @ basis.T for basis, dual in zip((weak, strong), duals, strict=False)]
    bound, chosen = _dual_bound(info, criterion, count, base, zs)
    return weights, bound, chosen, status, iterations


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
) -> Relaxation:
    crit = criterion_of(criterion)
    if isinstance(crit, SpectralCriterion):
        return sdp(info, crit, count, base, d_relaxation=first_order(info, D_OPTIMAL, count, base, start=start))
    relaxed = first_order(info, crit, count, base, start=start)
    if smooth(crit).newton and relaxed.bound is not None and count <= NEWTON_COUNT:
        # The multiplicative algorithm stops at a 0.01 gap; a few Newton steps from its weights close it (at
        # K = 30 of 2 000: 180.6636 -> 180.654, ~5 iterations). Only the bound is taken: rounding and exchange
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
