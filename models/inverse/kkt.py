"""Newton on the optimality conditions of the inverse-kinematics NLP, for whole batches.

The NLP of `nlp.py` without its bounds: minimise Σ wⱼ (jointⱼ(v) − seedⱼ)² subject to
c(v) = 0 (TCP on target), v = [carriage joints, platform pose] (the same
`ik_problem`, the same weights). Its KKT conditions F(v, λ) = [∇d + Aᵀλ; c] = 0
are solved by Newton's method with the exact Jacobian of F (second derivatives
of the constraints included), from CasADi's AD, compiled and evaluated over
all targets at once. Where no bound is active at the result, it is the IPOPT
solution (a KKT point of the bounded problem too); a test checks that the two
agree. Targets where a bound would be violated, or Newton does not converge,
go to IPOPT.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from models.description.robot import RobotDescription
from models.engine import cancellation
from models.engine.batch import BatchFunctions
from models.engine.native import compile_functions
from models.engine.runtime import Runtime, runtime_for
from models.inverse.problem import ik_problem


def _functions(desc: RobotDescription) -> list[ca.Function]:
    ik = ik_problem(desc)
    out = []
    for label, c in (("pose", ik.equations(position_only=False)), ("position", ik.equations(position_only=True))):
        lam = ca.SX.sym("lam", c.numel())
        f = ca.vertcat(ca.gradient(ik.distance + ca.dot(lam, c), ik.v), c)
        jf = ca.jacobian(f, ca.vertcat(ik.v, lam))
        out.append(
            ca.Function(
                f"ik_kkt_{label}",
                [ik.v, lam, ik.target, ik.seed, ik.weights, ik.theta],
                [ca.densify(f), ca.densify(jf), ik.joints],
                ["v", "lam", "target", "seed", "weights", "params"],
                ["F", "JF", "joints"],
            )
        )
    return out


def kkt_functions(desc: RobotDescription, runtime: Runtime | None = None) -> BatchFunctions:
    """Compiled KKT residuals and Jacobians of this structure, built once by its runtime."""
    rt = runtime_for(desc, runtime)

    def build() -> BatchFunctions:
        fns = _functions(desc)
        return BatchFunctions(functions={f.name(): f for f in fns}, native=compile_functions("ik_" + rt.tag, fns))

    return rt.artefact("kkt", None, build)


def _solve(jf: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Batched Newton steps; NaN for singular systems (those targets count as not converged)."""
    try:
        return np.linalg.solve(jf, -f[..., None])[..., 0]
    except np.linalg.LinAlgError:
        pass
    # Some system is singular (a serial arm with a joint held at its limit has fewer free joints than equations):
    # those rows get NaN and the rest one batched solve. Row by row, as before, the iiwa-like arm's 250 targets
    # from the default seed took 110 000 single solves: 1.4 s of CPU instead of 1.2.
    out = np.full(f.shape, np.nan)
    sign, _ = np.linalg.slogdet(jf)  # exactly 0 where LU meets a zero pivot, what makes solve raise
    regular = np.flatnonzero(sign != 0.0)
    try:
        out[regular] = np.linalg.solve(jf[regular], -f[regular][..., None])[..., 0]
    except np.linalg.LinAlgError:  # a pivot slogdet's LU passed and solve's did not: row by row after all
        for i in regular:
            try:
                out[i] = np.linalg.solve(jf[i], -f[i])
            except np.linalg.LinAlgError:
                continue
    return out


FULL_TURN = 2.0 * np.pi
QUADRATIC_STEP = 1e-7
"""A Newton step this small (rad, mm) with the equations within a thousand times it ends the iteration: the step
solves their linearisation, so what it leaves is of the order of its square times the TCP's curvature (under
1e4 mm/rad² on any arm here): below 1e-10 mm, where a further iteration would only confirm it."""
STEP_REACH = 0.5
"""A Newton step moves no variable (a full-turn joint excepted) by more than this fraction of its box's width;
a longer one is scaled down as a whole (a damped Newton step: same direction; near the solution the steps are
short and Newton's own).
The first round starts with no multiplier estimate, so its first steps model the objective without the TCP
equations' curvature: on the IWR they jumped by up to 870 mm on its 800 mm carriage axis and 2.5 rad on a
platform angle whose box is 0.35 rad wide, the linearisation taken far beyond where it holds, and Newton
diverged or oscillated (1 000 FK targets: 49 first rounds, no bound held, did not converge; the later rounds,
from a clipped point, likewise). The answer lies inside the box, so half its width is already a long step.
Measured on two sets of 1 000 FK targets, with the active set below: undamped, 968 and 964 solved; a reach of
0.25 to 2 box widths, 995 to 998 each, with IPOPT's answers but for one target of one set at every reach (as
undamped) and one of the other from a reach of 1 up (another local minimum, 2 % further from the seed)."""
FULL_RANK = 1e-9
"""The equations' Jacobian over the free variables (columns in box widths) has lost rank where its smallest
singular value is below this fraction of its largest: on the IWR 1e-21 to 1e-16 where the free variables
cannot turn the tool about every axis (three of its five rotations fixed), 2e-5 or more otherwise."""


def wrapped(angles: np.ndarray, seed: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """`angles` turned by whole turns to the value nearest `seed` within [lower, upper] (ranges of a full turn
    or more; an angle already in range moves only when a whole turn brings it nearer the seed)."""
    turns = np.round((seed - angles) / FULL_TURN)
    out = angles + FULL_TURN * turns
    out = np.where(out > upper + 1e-12, out - FULL_TURN, out)
    out = np.where(out < lower - 1e-12, out + FULL_TURN, out)
    return np.where(np.isfinite(angles), out, angles)


def _newton(
    fns: BatchFunctions,
    name: str,
    v: np.ndarray,
    lam: np.ndarray,
    *,
    fixed: np.ndarray,
    value: np.ndarray,
    reach: np.ndarray,
    data: tuple[np.ndarray, ...],
    theta: np.ndarray,
    iterations: int,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Newton on the KKT system with the `fixed` variables held at `value`, from (v, lam), no step moving a
    variable further than its `reach`; (v, lam, converged, stationarity rows, the equations' Jacobian).

    The last two are those of the last evaluation (one step before the end): what the active set's decisions
    need (a fixed variable's stationarity row is minus its bound multiplier; the Jacobian's rank says whether the
    free variables can still satisfy the equations)."""
    n, k = v.shape
    v, lam = v.copy(), lam.copy()
    v[fixed] = value[fixed]
    grad = np.zeros((n, k))
    jac = np.zeros((n, lam.shape[1], k))
    todo = np.arange(n)
    converged = np.zeros(n, dtype=bool)
    for _ in range(iterations):
        cancellation.check()  # a batch whose client left stops at its next Newton step
        f, jf, _ = fns.batch(name, v[todo], lam[todo], *(d[todo] for d in data), theta)
        grad[todo] = f[:, :k]
        jac[todo] = jf[:, k:, :k]
        # A fixed variable's stationarity row becomes "stay at the bound"; its bound multiplier absorbs the rest.
        ii, kk = np.nonzero(fixed[todo])
        jf[ii, kk, :] = 0.0
        jf[ii, kk, kk] = 1.0
        f[ii, kk] = 0.0
        step = _solve(jf, f)
        # A step that is not finite everywhere (an overflowed solve) is no step: NaN, as a singular system's, so
        # no infinite value reaches the caller's arithmetic (an inf among NaNs did: the iiwa-like arm's
        # multistart squared one).
        step[~np.isfinite(step).all(axis=1)] = np.nan
        # Damped where the step is long (the whole step scaled, its direction kept): see STEP_REACH.
        ratio = np.max(np.abs(step[:, :k]) / reach, axis=1)
        step[ratio > 1.0] /= ratio[ratio > 1.0, None]
        v[todo] += step[:, :k]
        lam[todo] += step[:, k:]
        residual, moved = np.abs(f[:, k:]).max(axis=1), np.abs(step[:, :k]).max(axis=1)
        done = ((residual <= tolerance) & (moved <= tolerance)) | (
            (moved <= QUADRATIC_STEP) & (residual <= QUADRATIC_STEP * 1e3)
        )
        converged[todo[done]] = True
        todo = todo[~done & np.isfinite(step).all(axis=1)]
        if todo.size == 0:
            break
    return v, lam, converged & np.isfinite(v).all(axis=1), grad, jac


def _worst_violation(
    v: np.ndarray, lower: np.ndarray, upper: np.ndarray, fixed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(low, high): per target, the one free variable furthest outside its box (relative to the box's width),
    below or above it. One at a time: fixing every variable that left its box at once can leave fewer free
    variables than TCP equations, or fix one that only left because another did (the IWR, 1 000 FK targets:
    a target's unbounded solution has 2-10 of its 10 variables outside; all fixed at once, 168 went on to
    IPOPT)."""
    span = np.where(np.isfinite(upper - lower) & (upper > lower), upper - lower, 1.0)
    excess = np.maximum(lower - v, v - upper) / span
    excess = np.where(fixed | ~np.isfinite(excess), -np.inf, excess)
    worst = np.argmax(excess, axis=1)
    rows = np.arange(v.shape[0])
    out = excess[rows, worst] > 1e-12
    one = np.zeros(v.shape, dtype=bool)
    one[rows[out], worst[out]] = True
    return one & (v < lower), one & (v > upper)


def _released(grad: np.ndarray, at_low: np.ndarray, at_high: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Per target, the one fixed variable whose bound multiplier has the wrong sign (the objective would improve
    moving it inwards) by the most, in box widths. One at a time, as in any active-set method: releasing two at
    once let a set cycle (the IWR: {q3, β} released together went back to {}, round after round, where IPOPT's
    answer holds q3 alone)."""
    wrong = np.where(at_low, -grad, np.where(at_high, grad, -np.inf)) * width
    worst = np.argmax(wrong, axis=1)
    rows = np.arange(grad.shape[0])
    out = np.zeros(grad.shape, dtype=bool)
    pick = wrong[rows, worst] > 0.0
    out[rows[pick], worst[pick]] = True
    return out


def _full_rank(jac: np.ndarray, free: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Whether the equations' Jacobians (N, m, k) over the `free` variables (N, k) keep rank m."""
    sv = np.linalg.svd(jac * (free * width)[:, None, :], compute_uv=False)
    return np.asarray(sv[:, -1] > FULL_RANK * sv[:, 0])


def _swapped(
    jac: np.ndarray, fixed: np.ndarray, adding: np.ndarray, held: np.ndarray, *, width: np.ndarray, where: np.ndarray
) -> np.ndarray:
    """For the targets (`where`) where fixing `adding` would leave free variables that cannot satisfy the
    equations (the IWR: three of its five rotations fixed, so the tool cannot turn about every axis), the fixed
    variable to release with it: of those whose release restores the rank, the one its bound holds least
    (`held`: the bound multiplier in box widths). Newton on such a set cannot converge and its multipliers are
    not unique; the rounds went on with it to IPOPT (the IWR: 3 and 1 more of two sets of 1 000 FK targets)."""
    out = np.zeros(fixed.shape, dtype=bool)
    wanted = fixed | adding
    rows = np.flatnonzero(where & adding.any(axis=1))
    lost = rows[~_full_rank(jac[rows], ~wanted[rows], width)]
    if lost.size == 0:
        return out
    best = np.full(lost.size, -1)
    best_held = np.full(lost.size, np.inf)
    for i in range(fixed.shape[1]):
        trial = wanted[lost].copy()
        trial[:, i] = False
        better = fixed[lost, i] & _full_rank(jac[lost], ~trial, width) & (held[lost, i] < best_held)
        best[better], best_held[better] = i, held[lost, i][better]
    found = best >= 0
    out[lost[found], best[found]] = True
    return out


def newton_kkt(
    fns: BatchFunctions,
    v: np.ndarray,
    target: np.ndarray,
    *,
    seed: np.ndarray,
    weights: np.ndarray,
    theta: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    position_only: bool,
    periodic: np.ndarray | None = None,
    iterations: int = 15,
    rounds: int = 16,
    tolerance_mm: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray]:
    """(v, converged) for every target: Newton on the KKT system inside an active set of box bounds.

    Of the variables that leave their box, the one furthest outside is fixed at its bound (one a round); of the
    fixed ones whose bound multiplier has the wrong sign (the objective would improve moving inwards), the most
    wrong is released; where the new bound would leave free variables that cannot satisfy the equations (after
    a round that converged), the fixed one held least that restores them is released with it; repeat
    until the set settles (at most `rounds` times). Newton's steps are damped to `STEP_REACH` of a box.
    Converged: the TCP equations hold to `tolerance_mm` and the last step moved nothing by more than that, or
    the last step was below `QUADRATIC_STEP` (what it leaves is below `tolerance_mm`: one evaluation fewer a
    solve); and the set is settled.
    `periodic`: the variables (revolute joints whose range spans a full turn) that are first turned by whole
    turns back into their range, nearest the seed: there they are the same pose, not a bound to hold (nor a box
    to damp steps by).
    """
    # Long on purpose: one vectorised active-set iteration; its state (active bounds, step, convergence) is
    # shared by every line.
    name = "ik_kkt_position" if position_only else "ik_kkt_pose"
    m = 3 if position_only else 6
    n, k = v.shape
    finite = np.isfinite(upper - lower) & (upper > lower)
    width = np.where(finite, upper - lower, 1.0)
    reach = np.where(finite, STEP_REACH * (upper - lower), np.inf)
    if periodic is not None:
        # A joint turned back into its range by whole turns has no box the answer must lie in: undamped. (Damped,
        # the UR5-like arm's program compensation found the nominal solution on another branch for 2 of 10 000
        # targets and on the taught one for 2 others.)
        reach[periodic] = np.inf
    fixed = np.zeros((n, k), dtype=bool)
    value = np.zeros((n, k))
    lam = np.zeros((n, m))
    out = v.copy()
    settled = np.zeros(n, dtype=bool)
    ok = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    for _ in range(rounds):
        data = (target[todo], seed[todo], weights[todo])
        vt, lt, conv, grad, jac = _newton(
            fns,
            name,
            v[todo],
            lam[todo],
            fixed=fixed[todo],
            value=value[todo],
            reach=reach,
            data=data,
            theta=theta,
            iterations=iterations,
            tolerance=tolerance_mm,
        )
        if periodic is not None and periodic.any():
            vt[:, periodic] = wrapped(vt[:, periodic], seed[todo][:, periodic], lower[periodic], upper[periodic])
        out[todo], ok[todo] = vt, conv
        f = fixed[todo]
        low, high = _worst_violation(vt, lower, upper, f)
        at_low = f & (value[todo] == lower)
        at_high = f & (value[todo] == upper)
        # A release also after a round that did not converge: the set may be why (releasing only after converged
        # rounds left 4 and 8 more of two sets of 1 000 IWR targets to IPOPT). A swap only after one that did:
        # after the others it kept a 7-joint arm's hopeless starts swapping bounds round after round (its
        # multistart, 143 targets x 33 starts: 4.4 s instead of 1.2) and solved no more IWR targets.
        release = _released(grad, at_low, at_high, width)
        held = np.where(at_low, grad, -grad) * width
        release |= _swapped(jac, f, low | high, held, width=width, where=conv)
        changed = (low | high | release).any(axis=1)
        f[low | high] = True
        f[release] = False
        fixed[todo] = f
        val = value[todo]
        val[low] = np.broadcast_to(lower, val.shape)[low]
        val[high] = np.broadcast_to(upper, val.shape)[high]
        value[todo] = val
        settled[todo[~changed]] = True
        v[todo] = np.clip(vt, lower, upper)
        # A converged round's equation multipliers start the next (fixing or releasing a bound leaves them
        # nearly right); after one that did not converge they are no estimate.
        lam[todo] = np.where(conv[:, None], lt, 0.0)
        # Another round also for a target whose Newton did not converge but stayed finite: with a variable
        # outside its box its unbounded problem may have no nearby solution; fixed at the bound it has one.
        todo = todo[changed & (conv | np.isfinite(vt).all(axis=1))]
        if todo.size == 0:
            break
    return out, ok & settled
