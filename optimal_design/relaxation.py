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
identifiable directions). The SDPs are posed in the basis that whitens the
candidates' mean information, with the constant matrices of the constraints
transformed alongside, so the cone sees an O(1) spectrum and the problem is
unchanged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import cvxpy as cp
import numpy as np

from models.kinematics import Array
from optimal_design.criteria import Criterion
from optimal_design.information import CandidateInformation

MAX_ITERATIONS = 3000
GAP_D = 0.01
"""Stop the D iterations when the bound is within this of log det (an efficiency gap of 0.02 % at P = 54)."""
GAP_RELATIVE = 1e-3
SCREENED = 240
TIME_LIMIT_S = 40.0


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
    """min(1, c·values) with c chosen so the sum is `total` (values ≥ 0, enough of them positive)."""
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


def _topk(g: Array, k: int) -> float:
    return float(np.partition(g, g.size - k)[g.size - k :].sum()) if k > 0 else 0.0


def gradient(info: CandidateInformation, criterion: Criterion, m: Array) -> tuple[float, Array]:
    """(f(M), ∂f/∂wᵢ) for the smooth concave criteria D (log det), A (−tr M⁻¹), I (−tr L M⁻¹)."""
    inv = np.linalg.inv(m)
    if criterion is Criterion.D:
        f = float(np.linalg.slogdet(m)[1])
        q = inv
    else:
        lm = np.eye(m.shape[0]) if criterion is Criterion.A else info.task
        f = -float(np.trace(lm @ inv))
        q = inv @ lm @ inv
    g = np.einsum("mri,ij,mrj->m", info.blocks, q, info.blocks, optimize=True)
    return f, g


def first_order(info: CandidateInformation, criterion: Criterion, count: int, base: Array) -> Relaxation:
    """Capped multiplicative algorithm with its Frank–Wolfe certificate (D, A, I)."""
    started = time.perf_counter()
    w = np.full(info.size, count / info.size)
    power = 1.0 if criterion is Criterion.D else 0.5
    bound, f, it = np.inf, -np.inf, 0
    for it in range(1, MAX_ITERATIONS + 1):  # noqa: B007
        f, g = gradient(info, criterion, base + info.information(w))
        bound = min(bound, f + _topk(g, count) - float(g @ w))
        tol = GAP_D if criterion is Criterion.D else GAP_RELATIVE * abs(f)
        if bound - f <= tol or time.perf_counter() - started > TIME_LIMIT_S:
            break
        w = capped(w * np.maximum(g, 0.0) ** power, count)
    return Relaxation(
        weights=w,
        bound=float(bound),
        method="capped multiplicative algorithm, Frank–Wolfe gap certificate",
        status="optimal" if bound - f <= (GAP_D if criterion is Criterion.D else GAP_RELATIVE * abs(f)) else "gap open",
        iterations=it,
        seconds=time.perf_counter() - started,
    )


def _screen(info: CandidateInformation, count: int, base: Array) -> Array:
    """Candidates the E / condition SDP is posed on: the D relaxation's support and its strongest runners-up."""
    d = first_order(info, Criterion.D, count, base)
    order = np.argsort(-d.weights)
    return np.sort(order[: min(info.size, max(SCREENED, 4 * count))])


def _whitening(info: CandidateInformation, index: Array) -> tuple[Array, Array]:
    mean = info.subset_information(index) / index.size
    ev, vec = np.linalg.eigh((mean + mean.T) / 2)
    return vec / np.sqrt(ev), ev


def sdp(info: CandidateInformation, criterion: Criterion, count: int, base: Array) -> Relaxation:
    """E or condition by cvxpy + Clarabel on screened candidates; bound over all from the dual matrices."""
    started = time.perf_counter()
    index = _screen(info, count, base)
    t_mat, ev = _whitening(info, index)
    p = info.n_params
    tau = cp.Variable(nonneg=True)
    w = cp.Variable(index.size, nonneg=True)

    def information(rows: Array, fixed: Array) -> cp.Expression:
        f = np.einsum("mri,mrj->mij", rows, rows).reshape(index.size, p * p)
        flat = cp.reshape(f.T @ w, (p, p), order="C")
        # The condition problem is homogenised (w stands for τ·w), so the measured poses scale with τ too.
        return (flat + flat.T) / 2 + (fixed if criterion is Criterion.E else tau * fixed)

    # λ_min lives in the weakest directions: pose "M ⪰ s·I" in the basis that whitens the mean information,
    # where it reads T ᵀM T ⪰ s·diag(1/ev); scaled by ev_min, every entry is ≤ 1 and the binding ones are O(1).
    whitened = information(info.blocks[index] @ t_mat, t_mat.T @ base @ t_mat)
    low = np.diag(ev[0] / ev)
    if criterion is Criterion.E:
        s = cp.Variable()
        lower = whitened - s * low >> 0
        problem = cp.Problem(cp.Maximize(s), [lower, cp.sum(w) == count, w <= 1])
        constraints = [lower]
    else:
        # λ_max lives in the strongest: pose it in the original basis scaled by ev_max. Two LMIs in two bases,
        # both linear in w. Homogenised (u = τ·w, Σu = Kτ, u ≤ τ), the upper spectrum is pinned and the lower
        # one pushed up: max s with M(u) ⪰ s·ev_min·I, M(u) ⪯ ev_max·I, so cond(M) ≤ ev_max/(s·ev_min) — an
        # exact convex form of the quasi-convex problem, and one Clarabel solves reliably (the form with a
        # free upper bound t, min t s.t. I ⪯ M(u) ⪯ t·I, fails on these spectra).
        s = cp.Variable()
        plain = information(info.blocks[index] / np.sqrt(ev[-1]), base / ev[-1])
        lower = whitened - s * low >> 0
        upper = np.eye(p) - plain >> 0
        problem = cp.Problem(cp.Maximize(s), [lower, upper, cp.sum(w) == count * tau, w <= tau])
        constraints = [lower, upper]
    try:
        problem.solve(solver=cp.CLARABEL)
        status = str(problem.status)
    except cp.error.SolverError as exc:
        status = f"solver error: {exc}"
    weights = np.zeros(info.size)
    duals = [c.dual_value for c in constraints]
    if status != "optimal" or any(d is None for d in duals):
        fallback = _screened_weights(info, index, w.value, criterion)
        return Relaxation(
            weights=fallback if fallback is not None else _d_weights(info, count, base),
            bound=None,
            method="cvxpy + Clarabel SDP on screened candidates",
            status=status,
            iterations=int(problem.solver_stats.num_iters or 0) if problem.solver_stats else 0,
            seconds=time.perf_counter() - started,
            note=f"Clarabel did not solve the {criterion.value} relaxation to optimality ({status}): "
            "no bound is reported; the design comes from rounding and exchange on the exact criterion",
        )
    raw = np.asarray(w.value, dtype=float)
    if criterion is Criterion.CONDITION:
        raw = raw / max(float(np.asarray(tau.value)), 1e-300)
    weights[index] = np.clip(raw, 0.0, 1.0)
    # Back to the original basis: the lower LMI's dual through T, the upper one's is already there.
    zs = [t_mat @ np.asarray(duals[0], dtype=float) @ t_mat.T, *(np.asarray(d, dtype=float) for d in duals[1:])]
    bound = _dual_bound(info, criterion, count, base, zs)
    return Relaxation(
        weights=weights,
        bound=bound,
        method="cvxpy + Clarabel SDP on screened candidates, dual bound over all candidates",
        status=status,
        iterations=int(problem.solver_stats.num_iters or 0),
        seconds=time.perf_counter() - started,
    )


def _d_weights(info: CandidateInformation, count: int, base: Array) -> Array:
    return first_order(info, Criterion.D, count, base).weights


def _screened_weights(
    info: CandidateInformation, index: Array, values: Array | None, criterion: Criterion
) -> Array | None:
    if values is None:
        return None
    raw = np.clip(np.asarray(values, dtype=float), 0.0, None)
    if not np.isfinite(raw).all() or raw.sum() <= 0:
        return None
    out = np.zeros(info.size)
    out[index] = raw / raw.max()
    return out


def _traces(info: CandidateInformation, z: Array) -> Array:
    z = (z + z.T) / 2
    return np.einsum("mri,ij,mrj->m", info.blocks, z, info.blocks, optimize=True) / np.trace(z)


def _dual_bound(info: CandidateInformation, criterion: Criterion, count: int, base: Array, zs: list[Array]) -> float:
    """Bound on the utility of every K-subset from density matrices (see module docstring)."""
    if criterion is Criterion.E:
        z = zs[0]
        return float(np.trace(z @ base) / np.trace(z) + _topk(_traces(info, z), count))
    z1, z2 = zs
    a, b = _traces(info, z2), _traces(info, z1)
    a0, b0 = np.trace(z2 @ base) / np.trace(z2), np.trace(z1 @ base) / np.trace(z1)
    lo, hi = 0.0, float((a0 + _topk(a, count)) / max(b0 + _bottomk(b, count), 1e-300))
    hi = max(hi, 1.0)
    for _ in range(200):
        r = 0.5 * (lo + hi)
        if a0 - r * b0 + _bottomk(a - r * b, count) <= 0:
            hi = r
        else:
            lo = r
    ratio = lo  # no K-subset has λ_max/λ_min below this
    return -float(np.sqrt(max(ratio, 0.0)))  # utility of the condition criterion: −cond(J)


def _bottomk(g: Array, k: int) -> float:
    return float(np.partition(g, k - 1)[:k].sum()) if k > 0 else 0.0


def relax(info: CandidateInformation, criterion: Criterion, count: int, base: Array) -> Relaxation:
    if criterion in (Criterion.E, Criterion.CONDITION):
        return sdp(info, criterion, count, base)
    return first_order(info, criterion, count, base)
