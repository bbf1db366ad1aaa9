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

from models import cancellation
from models.batch import BatchFunctions
from models.inverse.problem import ik_problem
from models.native import compile_functions
from models.robot import RobotDescription
from models.runtime import Runtime, runtime_for


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
        out = np.full(f.shape, np.nan)
        for i in range(f.shape[0]):
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
    m: int,
    v: np.ndarray,
    *,
    fixed: np.ndarray,
    value: np.ndarray,
    data: tuple[np.ndarray, ...],
    theta: np.ndarray,
    iterations: int,
    tolerance: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Newton on the KKT system with the `fixed` variables held at `value`; (v, converged, stationarity rows)."""
    n, k = v.shape
    v = v.copy()
    v[fixed] = value[fixed]
    lam = np.zeros((n, m))
    grad = np.zeros((n, k))
    todo = np.arange(n)
    converged = np.zeros(n, dtype=bool)
    for _ in range(iterations):
        cancellation.check()  # a batch whose client left stops at its next Newton step
        f, jf, _ = fns.batch(name, v[todo], lam[todo], *(d[todo] for d in data), theta)
        grad[todo] = f[:, :k]
        # A fixed variable's stationarity row becomes "stay at the bound"; its bound multiplier absorbs the rest.
        ii, kk = np.nonzero(fixed[todo])
        jf[ii, kk, :] = 0.0
        jf[ii, kk, kk] = 1.0
        f[ii, kk] = 0.0
        step = _solve(jf, f)
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
    return v, converged & np.isfinite(v).all(axis=1), grad


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

    Of the variables that leave their box, the one furthest outside is fixed at its bound (one a round); a fixed
    one whose bound multiplier has the wrong sign (the objective would improve moving inwards) is released;
    repeat until the set settles (at most `rounds` times). Converged: the TCP
    equations hold to `tolerance_mm` and the last step moved nothing by more than that, or the last step was
    below `QUADRATIC_STEP` (what it leaves is below `tolerance_mm`: one evaluation fewer a solve); and the set is
    settled.
    `periodic`: the variables (revolute joints whose range spans a full turn) that are first turned by whole
    turns back into their range, nearest the seed: there they are the same pose, not a bound to hold.
    """
    # Long on purpose: one vectorised active-set iteration; its state (active bounds, step, convergence) is
    # shared by every line.
    name = "ik_kkt_position" if position_only else "ik_kkt_pose"
    m = 3 if position_only else 6
    n, k = v.shape
    fixed = np.zeros((n, k), dtype=bool)
    value = np.zeros((n, k))
    out = v.copy()
    settled = np.zeros(n, dtype=bool)
    ok = np.zeros(n, dtype=bool)
    todo = np.arange(n)
    for _ in range(rounds):
        data = (target[todo], seed[todo], weights[todo])
        vt, conv, grad = _newton(
            fns,
            name,
            m,
            v[todo],
            fixed=fixed[todo],
            value=value[todo],
            data=data,
            theta=theta,
            iterations=iterations,
            tolerance=tolerance_mm,
        )
        if periodic is not None and periodic.any():
            vt[:, periodic] = wrapped(vt[:, periodic], seed[todo][:, periodic], lower[periodic], upper[periodic])
        out[todo], ok[todo] = vt, conv
        low, high = _worst_violation(vt, lower, upper, fixed[todo])
        at_low = fixed[todo] & (value[todo] == lower)
        at_high = fixed[todo] & (value[todo] == upper)
        release = (at_low & (grad < 0)) | (at_high & (grad > 0))
        changed = (low | high | release).any(axis=1)
        f = fixed[todo]
        f[low | high] = True
        f[release] = False
        fixed[todo] = f
        val = value[todo]
        val[low] = np.broadcast_to(lower, val.shape)[low]
        val[high] = np.broadcast_to(upper, val.shape)[high]
        value[todo] = val
        settled[todo[~changed]] = True
        v[todo] = np.clip(vt, lower, upper)
        # Another round also for a target whose Newton did not converge but stayed finite: with a variable
        # outside its box its unbounded problem may have no nearby solution; fixed at the bound it has one.
        todo = todo[changed & (conv | np.isfinite(vt).all(axis=1))]
        if todo.size == 0:
            break
    return out, ok & settled
