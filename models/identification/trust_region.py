"""A trust-region least-squares finish for the campaigns IPOPT cannot close.

IPOPT sees the calibration as an NLP: its Newton steps solve with the Gauss–Newton Hessian JᵀJ, whose condition
number is the square of the Jacobian's. A position-only campaign of a 6-axis arm measured in a small region of
its workspace has a column-scaled Jacobian of condition ~1e8–1e9 (measured: 6e8 on 40 records of a line); JᵀJ is
then at 1e17, past double precision, and IPOPT's line searches stall on round-off until its iteration limit,
although the residuals had long reached the noise. A least-squares method that factors J itself (QR/SVD, never
JᵀJ) keeps a condition number of 1e9 well inside double precision: scipy's 'trf' with Jacobian column scaling
(Moré's `x_scale='jac'`) finishes those campaigns from where IPOPT stopped in a few iterations.

The loss is the problem's own (soft-ℓ1 and Huber are scipy's losses of the same form and scale), and a prior's
rows join the residuals as rows of their own, so the minimum is the one IPOPT was asked for.
"""

from __future__ import annotations

import time
from typing import Literal

import numpy as np
import scipy.optimize

from models._types import Array
from models.identification.options import RobustLoss
from models.identification.residuals import CampaignProblem
from models.identification.solver import SolverRun

UNOBSERVABLE_SIGMA = 1e-2
"""A direction of the unknowns (tolerance units) along which one tolerance moves the standardised residuals by
less than this is unobservable by the campaign: 100 tolerances would change them by under 1 σ. A Gauss–Newton
step along it is a linear extrapolation of millions of tolerances (measured: 40 records on a straight line,
singular values down to 2e-7 σ per tolerance, the "remaining" 9 σ² all in steps of 1e6 tolerances), not a gain
any solver could realise; convergence is judged on the observable directions."""

CONVERGED_DECREMENT = 1e-3
"""σ² a Gauss–Newton step could still gain on the observable directions: below this the fit is at its optimum for
every statistical purpose (one parameter's uncertainty is worth 1 σ²; 1e-3 σ² is a shift of 0.03 of it),
whatever the solver's own tests said on round-off."""

MAX_EVALUATIONS = 2000
"""Residual evaluations the finish may take (each a native batch, ~1 ms for 40 records)."""

SCIPY_LOSS: dict[RobustLoss, Literal["linear", "soft_l1", "huber"]] = {
    RobustLoss.NONE: "linear",
    RobustLoss.SOFT_L1: "soft_l1",
    RobustLoss.HUBER: "huber",
}


def trust_region_finish(problem: CampaignProblem, z0: Array, lower: Array, upper: Array) -> SolverRun:
    """scipy 'trf' on the problem's residuals and exact Jacobian from `z0` (IPOPT's end point)."""
    started = time.perf_counter()
    prior = problem.prior_rows

    def residuals(z: Array) -> Array:
        ev = problem.evaluate(z)
        if ev is None:
            # The model is undefined there (a hexapod that does not close): a huge residual makes 'trf' shrink
            # its region, as IPOPT backtracks from a NaN.
            rows = problem.active_poses.size * problem.rows + (0 if prior is None else prior.offset.size)
            return np.full(rows, 1e6)
        r = ev.residuals.reshape(-1)
        return r if prior is None else np.concatenate([r, prior.residuals(z)])

    def jacobian(z: Array) -> Array:
        ev = problem.evaluate(z)
        if ev is None:
            rows = problem.active_poses.size * problem.rows + (0 if prior is None else prior.offset.size)
            return np.zeros((rows, problem.n_free))
        return ev.jacobian if prior is None else np.vstack([ev.jacobian, prior.jacobian])

    x0 = _strictly_inside(z0, lower, upper)
    # MINPACK's Levenberg–Marquardt where it applies (no bounds, the plain loss): in the long flat valleys of
    # these campaigns (unknowns travelling hundreds of tolerances along a weak direction) it converges in a few
    # dozen evaluations where 'trf' spends its whole budget (measured: 40 records on a line, condition 6e8).
    plain = problem.loss.kind is RobustLoss.NONE and not (np.isfinite(lower).any() or np.isfinite(upper).any())
    fit = scipy.optimize.least_squares(
        residuals,
        x0,
        jac=jacobian,
        bounds=(lower, upper),
        method="lm" if plain else "trf",
        x_scale="jac",
        loss=SCIPY_LOSS.get(problem.loss.kind, "linear"),
        f_scale=problem.loss.scale if problem.loss.kind is not RobustLoss.NONE else 1.0,
        # The objective is χ²-like (a few hundred σ²): a relative change of 1e-12 is far below what a step
        # could matter statistically; the step test at 1e-10 of the unknowns (tolerances) likewise.
        ftol=1e-12,
        xtol=1e-10,
        gtol=1e-10,
        max_nfev=MAX_EVALUATIONS,
    )
    z = on_observable_directions(problem, np.asarray(fit.x, dtype=float))
    if fit.status <= 0 and gauss_newton_decrement(problem, z) >= CONVERGED_DECREMENT:
        z = _observable_steps(problem, z)
    ev = problem.evaluate(z)
    # scipy's tests are relative to round-off that a 1e9 condition number makes noisy (it can end on its
    # evaluation limit at the optimum): the decrement is the test that matters.
    converged = ev is not None and (fit.status > 0 or gauss_newton_decrement(problem, z) < CONVERGED_DECREMENT)
    return SolverRun(
        z=z,
        status=f"trust_region_{'converged' if converged else 'stopped'}",
        success=converged,
        iterations=int(fit.nfev),
        seconds=time.perf_counter() - started,
        objective=float("nan") if ev is None else ev.objective,
    )


def _strictly_inside(z0: Array, lower: Array, upper: Array) -> Array:
    """`z0` in the box, and strictly inside its finite bounds: where 'trf' wants its start."""
    x0 = np.clip(z0, lower, upper)
    inside = np.isfinite(lower) & np.isfinite(upper) & (upper > lower)
    x0[inside] = np.clip(x0[inside], lower[inside] + 1e-12 * (upper - lower)[inside], upper[inside])
    return x0


def on_observable_directions(problem: CampaignProblem, z: Array) -> Array:
    """`z` with its components along the unobservable directions put back to the start (0), then Gauss–Newton
    on the observable ones from there (plain loss, no prior, no bounds; the others keep `z`).

    Levenberg–Marquardt moves the unknowns thousands of tolerances along directions the records hardly see,
    following noise: harmless on the records, not off them. Measured on 40 records of a straight line (6 seeds):
    held-out error 0.99-1.18x an independent scipy fit before, 0.50-1.02x after."""
    if problem.loss.kind is not RobustLoss.NONE or problem.prior_rows is not None:
        return z
    ev = problem.evaluate(z)
    if ev is None:
        return z
    _, sv, vt = np.linalg.svd(ev.jacobian, full_matrices=False)
    seen = sv > UNOBSERVABLE_SIGMA
    if seen.all():
        return z
    projected = vt[seen].T @ (vt[seen] @ z)
    stepped = _observable_steps(problem, projected, steps=10)
    return stepped if gauss_newton_decrement(problem, stepped) < CONVERGED_DECREMENT else z


def _observable_steps(problem: CampaignProblem, z: Array, steps: int = 5) -> Array:
    """Gauss–Newton steps on the observable directions only (plain loss, no prior; the others keep scipy's end).
    Levenberg–Marquardt's damping is set by the weakest directions of an ill-conditioned campaign and can leave
    the observable ones short by a few 1e-3 σ² at its evaluation limit (measured: 2e-3 σ² after 2 000
    evaluations on 40 records of a line); these steps close that (to 3e-7 σ²)."""
    if problem.loss.kind is not RobustLoss.NONE or problem.prior_rows is not None:
        return z
    for _ in range(steps):
        ev = problem.evaluate(z)
        if ev is None:
            break
        u, sv, vt = np.linalg.svd(ev.jacobian, full_matrices=False)
        seen = sv > UNOBSERVABLE_SIGMA
        gain = u[:, seen].T @ ev.residuals.reshape(-1)
        if float(gain @ gain) < CONVERGED_DECREMENT / 100:
            break
        trial_z = z - vt[seen].T @ (gain / sv[seen])
        trial = problem.evaluate(trial_z)
        if trial is None or trial.objective >= ev.objective:
            break
        z = trial_z
    return z


def gauss_newton_decrement(problem: CampaignProblem, z: Array) -> float:
    """The χ² (σ²) a full Gauss–Newton step from `z` would gain along the observable directions, from the SVD of
    J itself (the normal equations would square its condition number); inf where the model is undefined at `z`. Robust
    losses: their IRLS weights at `z`. Bounds are not taken into account (a bounded fit is tested by scipy)."""
    ev = problem.evaluate(z)
    if ev is None:
        return float("inf")
    r = ev.residuals.reshape(-1)
    _, slope = problem.loss.rho(r**2)
    w = np.sqrt(slope)
    rows, rhs = ev.jacobian * w[:, None], -(w * r)
    if problem.prior_rows is not None:
        rows = np.vstack([rows, problem.prior_rows.jacobian])
        rhs = np.concatenate([rhs, -problem.prior_rows.residuals(z)])
    u, sv, _ = np.linalg.svd(rows, full_matrices=False)
    seen = sv > UNOBSERVABLE_SIGMA
    gain = u[:, seen].T @ rhs
    return float(gain @ gain)


def unobservable_directions(jacobian: Array) -> tuple[Array, Array]:
    """(singular values, right singular vectors as rows) of the directions `jacobian` (σ per tolerance) leaves
    unobservable (`UNOBSERVABLE_SIGMA`), weakest first."""
    _, sv, vt = np.linalg.svd(jacobian, full_matrices=False)
    weak = np.flatnonzero(sv <= UNOBSERVABLE_SIGMA)[::-1]
    return sv[weak], vt[weak]


SHOWN_DIRECTIONS = 4
"""Directions a message spells out (the weakest); the rest are counted."""


def describe_unobservable(jacobian: Array, names: tuple[str, ...], *, most: int = 3) -> tuple[str, tuple[str, ...]]:
    """('' , ()) when every direction is observable; otherwise a sentence naming the unobservable directions by
    their largest components (`names` of the columns), and the parameters to hold: per direction, the one with
    the largest component (holding it pins that direction)."""
    sv, directions = unobservable_directions(jacobian)
    if not sv.size:
        return "", ()
    parts, hold = [], []
    for value, v in zip(sv, directions, strict=True):
        order = np.argsort(-np.abs(v))
        top = [f"{v[i]:+.2f}·{names[i]}" for i in order[:most] if abs(v[i]) >= 0.1]
        parts.append(f"{' '.join(top)} ({value:.1e} σ per tolerance)")
        first = names[order[0]]
        if first not in hold:
            hold.append(first)
    shown = "; ".join(parts[:SHOWN_DIRECTIONS]) + (
        f"; and {len(parts) - SHOWN_DIRECTIONS} more" if len(parts) > SHOWN_DIRECTIONS else ""
    )
    sentence = (
        f"{sv.size} direction(s) of the parameters are unobservable in these records (100 tolerances along them "
        f"move the measurements by under 1 σ), weakest first: {shown}"
    )
    return sentence, tuple(hold)
