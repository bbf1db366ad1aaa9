"""Newton on the optimality conditions of the inverse-kinematics NLP, for whole batches.

The NLP of `nlp.py` without its bounds: minimise Σ wⱼ (jointⱼ(v) − seedⱼ)² subject to
c(v) = 0 (TCP on target), v = [carriage joints, platform pose]. Its KKT
conditions F(v, λ) = [∇d + Aᵀλ; c] = 0 are solved by Newton's method with the
exact Jacobian of F (second derivatives of the constraints included), from
CasADi's AD, compiled and evaluated over all targets at once. Where no bound is
active at the result, it is the IPOPT solution (a KKT point of the bounded
problem too); a test checks that the two agree. Targets where a bound would be
violated, or Newton does not converge, go to IPOPT.
"""

from __future__ import annotations

import threading
from typing import Any

import casadi as ca
import numpy as np

from models import hexapod as hx
from models.compensation.nlp import ORIENTATION_LENGTH_MM, orientation_error
from models.function_cache import RobotFunctions
from models.hybrid import RobotDescription, tcp_transform
from models.native import compile_functions

_LOCK = threading.Lock()
_BUILT: dict[tuple[Any, ...], RobotFunctions] = {}


def _functions(desc: RobotDescription) -> list[ca.Function]:
    n_chain = desc.n_chain
    s_hex = desc.slices["hexapod"]
    q = ca.SX.sym("q_chain", n_chain)
    x = ca.SX.sym("platform", 6)
    theta = ca.SX.sym("params", desc.n_params)
    target = ca.SX.sym("target", 12)
    seed = ca.SX.sym("seed", desc.n_joints)
    weights = ca.SX.sym("weights", desc.n_joints)
    """Already divided by the squared range of each joint."""
    v = ca.vertcat(q, x)
    joints = ca.vertcat(q, hx.actuator_lengths(x, theta[s_hex]))
    distance = ca.sum1(weights * (joints - seed) ** 2)
    t = tcp_transform(desc, q, x, theta)
    position_error = t[0:3, 3] - target[0:3]
    rotation_error = orientation_error(t[0:3, 0:3], ca.reshape(target[3:12], 3, 3)) * ORIENTATION_LENGTH_MM
    out = []
    for label, c in (("pose", ca.vertcat(position_error, rotation_error)), ("position", position_error)):
        lam = ca.SX.sym("lam", c.numel())
        f = ca.vertcat(ca.gradient(distance + ca.dot(lam, c), v), c)
        jf = ca.jacobian(f, ca.vertcat(v, lam))
        out.append(
            ca.Function(
                f"ik_kkt_{label}",
                [v, lam, target, seed, weights, theta],
                [ca.densify(f), ca.densify(jf), joints],
                ["v", "lam", "target", "seed", "weights", "params"],
                ["F", "JF", "joints"],
            )
        )
    return out


def kkt_functions(desc: RobotDescription) -> RobotFunctions:
    """Compiled KKT residuals and Jacobians, once per robot structure."""
    structure = tuple(link.joint for link in desc.links)
    with _LOCK:
        found = _BUILT.get(structure)
        if found is None:
            fns = _functions(desc)
            tag = "ik_" + "".join("p" if j.value == "prismatic" else "r" for j in structure)
            found = RobotFunctions(
                structure=structure,
                n_joints=desc.n_joints,
                n_params=desc.n_params,
                functions={f.name(): f for f in fns},
                native=compile_functions(tag, fns),
                build_seconds=0.0,
            )
            _BUILT[structure] = found
        return found


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


def _newton(
    fns: RobotFunctions,
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
        done = (np.abs(f[:, k:]).max(axis=1) <= tolerance) & (np.abs(step[:, :k]).max(axis=1) <= tolerance)
        converged[todo[done]] = True
        todo = todo[~done & np.isfinite(step).all(axis=1)]
        if todo.size == 0:
            break
    return v, converged & np.isfinite(v).all(axis=1), grad


def newton_kkt(
    fns: RobotFunctions,
    v: np.ndarray,
    target: np.ndarray,
    *,
    seed: np.ndarray,
    weights: np.ndarray,
    theta: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    position_only: bool,
    iterations: int = 15,
    rounds: int = 6,
    tolerance_mm: float = 1e-10,
) -> tuple[np.ndarray, np.ndarray]:
    """(v, converged) for every target: Newton on the KKT system inside an active set of box bounds.

    A variable that leaves its box is fixed at the bound; a fixed one whose bound multiplier has the wrong sign
    (the objective would improve moving inwards) is released; repeat until the set settles. Converged: the TCP
    equations hold to `tolerance_mm`, the last step moved nothing by more than that, and the set is settled.
    """
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
        out[todo], ok[todo] = vt, conv
        low = (vt < lower - 1e-12) & ~fixed[todo]
        high = (vt > upper + 1e-12) & ~fixed[todo]
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
        todo = todo[changed & conv]
        if todo.size == 0:
            break
    return out, ok & settled
