"""IPOPT through CasADi, built once per number of unknowns and reused for every campaign.

The pool of solvers belongs to the structure's runtime (`solver_pool`).

Why not a CasADi graph of the whole campaign: its size, and so its build time,
grows with N, and a service sees a new N in almost every request (measured in
`benchmarks/bench_identification.py`: the nested-rootfinder NLP and the
implicit formulation with platform poses as variables both pay seconds of
building per new N). Here the NLP handed to IPOPT has only the n free
parameters as variables; its objective, gradient and Gauss–Newton Hessian are
callbacks into `CampaignProblem`, which evaluates the compiled per-pose CasADi
Functions (exact AD derivatives, implicit-function-theorem through the
hexapod) over the batch. The NLP therefore depends on n alone: one build of a
few milliseconds per n, then pooled.

Gauss–Newton rather than the exact Hessian: at a well-posed calibration the
residuals are noise, so the second-order term is O(σ) of the first and only
costs time; Gauss–Newton is also positive semi-definite, which IPOPT needs no
regularisation for.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from models._types import Array
from models.engine import cancellation
from models.engine.runtime import Runtime
from models.identification.residuals import FitProblem
from models.identification.result import SolverReport

IPOPT_OPTIONS: dict[str, Any] = {
    "ipopt.print_level": 0,
    "ipopt.sb": "yes",
    "print_time": False,
    # A NaN objective is our signal that a trial step broke a hexapod closure; IPOPT backtracks.
    "show_eval_warnings": False,
    # The objective is a mean per equation (≈ ½ at the solution) and the unknowns are in tolerances.
    # Below ~1e-7 the objective's round-off (warm-started hexapod Newton, rotation logarithms) makes line
    # searches stall; a remaining gradient of 1e-6 moves the TCP by well under 0.1 µm (tested).
    "ipopt.tol": 1e-9,
    "ipopt.acceptable_tol": 1e-6,
    "ipopt.acceptable_iter": 1,
    "ipopt.mu_strategy": "adaptive",
    # The Jacobian is in σ per tolerance, already well scaled; IPOPT's own gradient scaling would only
    # loosen the stopping test.
    "ipopt.nlp_scaling_method": "none",
    # At σ of a few µm the objective's round-off floor is reached before IPOPT's dual infeasibility test is:
    # each further line search backtracks 20–28 times on noise (measured: a ballbar fit, 13 iterations and
    # 226 evaluations for what 2 iterations found; 177 ms against 10 ms). The watchdog after 3 shortened
    # steps instead of 10 ends it in 6 iterations (36 ms), leaving the polish to finish.
    "ipopt.watchdog_shortened_iter_trigger": 3,
}


PAST_SOLVES = 20
"""Solves a solver remembers the iteration counts of, for the ETA of the next."""


class _Callback(ca.Callback):  # type: ignore[misc]  # CasADi is untyped (pyproject: follow_imports skip)
    """A CasADi Function whose value comes from Python (the current campaign's problem)."""

    def __init__(self, name: str, owner: _Solver, kind: str, n: int, jacobian: ca.Function | None = None) -> None:
        ca.Callback.__init__(self)
        self.owner, self.kind, self.n, self.jac = owner, kind, n, jacobian
        self.inputs = {"f": [n, 0], "grad": [n, 0], "jac": [n, 0, 1], "hess": [n, 0, 1, 0]}[kind]
        self.construct(name, {})

    def get_n_in(self) -> int:
        return len(self.inputs)

    def get_n_out(self) -> int:
        return {"f": 1, "grad": 2, "jac": 2, "hess": 1}[self.kind]

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(self.inputs[i], 1)

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        n = self.n
        shapes = {
            "f": [ca.Sparsity.dense(1, 1)],
            "grad": [ca.Sparsity.dense(1, 1), ca.Sparsity.dense(n, 1)],
            "jac": [ca.Sparsity.dense(1, n), ca.Sparsity.dense(1, 0)],
            "hess": [ca.Sparsity.upper(n)],
        }
        return shapes[self.kind][i]

    def has_jacobian(self) -> bool:
        return self.jac is not None

    def get_jacobian(self, name: str, inames: list[str], onames: list[str], opts: dict[str, Any]) -> ca.Function:
        return self.jac

    def eval(self, args: list[ca.DM]) -> list[Any]:
        z = np.asarray(args[0], dtype=float).reshape(-1)
        ev = self.owner.problem().evaluate(z)
        if ev is None:
            # IPOPT treats a non-finite value as "step too long" and backtracks.
            nan = float("nan")
            failed: dict[str, list[Any]] = {
                "f": [nan],
                "grad": [nan, np.full(self.n, nan)],
                "jac": [np.full((1, self.n), nan), np.zeros((1, 0))],
                "hess": [ca.DM(ca.Sparsity.upper(self.n), nan)],
            }
            return failed[self.kind]
        if self.kind == "f":
            return [ev.objective]
        if self.kind == "grad":
            return [ev.objective, ev.gradient]
        if self.kind == "jac":
            return [ev.gradient[None, :], np.zeros((1, 0))]
        sigma = float(np.asarray(args[2]).reshape(-1)[0])
        return [ca.triu(ca.DM(sigma * ev.hessian))]


class _StopWhenCancelled(ca.Callback):  # type: ignore[misc]
    """IPOPT's iteration callback (nlpsol option `iteration_callback`): called once per iteration with the
    solver's outputs; a nonzero answer stops IPOPT with `User_Requested_Stop` (checked against CasADi 3.8).
    It answers whether the current computation's cancellation token is set (models.engine.cancellation)."""

    def __init__(self, n: int) -> None:
        ca.Callback.__init__(self)
        self.n = n
        self.iteration = 0
        self.started = time.perf_counter()
        self.expected: int | None = None
        """The median iteration count of this solver's past solves: what a job's ETA assumes."""
        self.construct(f"stop_{n}", {})

    def begin(self, past: list[int]) -> None:
        self.iteration, self.started = 0, time.perf_counter()
        self.expected = int(np.median(past)) if past else None

    def get_n_in(self) -> int:
        return int(ca.nlpsol_n_out())

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return str(ca.nlpsol_out(i))

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        name = ca.nlpsol_out(i)
        if name in ("x", "lam_x"):
            return ca.Sparsity.dense(self.n, 1)
        if name == "f":
            return ca.Sparsity.dense(1, 1)
        return ca.Sparsity(0, 0) if name == "lam_p" else ca.Sparsity.dense(0, 1)

    def eval(self, args: list[ca.DM]) -> list[Any]:
        self.iteration += 1
        step = cancellation.Step(self.iteration, self.expected, time.perf_counter() - self.started)
        return [1 if cancellation.step(step) else 0]


class _Solver:
    def __init__(self, n: int, max_iter: int) -> None:
        self.n = n
        self._problem: FitProblem | None = None
        self._callbacks = [
            _Callback("lsq_grad", self, "grad", n),
            _Callback("lsq_hess", self, "hess", n),
        ]
        jac = _Callback("lsq_jac", self, "jac", n)
        f = _Callback("lsq_f", self, "f", n, jacobian=jac)
        self._iterations = _StopWhenCancelled(n)
        self._callbacks += [jac, f, self._iterations]
        self._past: list[int] = []
        """Iteration counts of the last solves (a job's ETA)."""
        z = ca.MX.sym("z", n)
        options = {
            **IPOPT_OPTIONS,
            "ipopt.max_iter": max_iter,
            "grad_f": self._callbacks[0],
            "hess_lag": self._callbacks[1],
            "iteration_callback": self._callbacks[-1],
        }
        self.nlp = ca.nlpsol(f"calibration_{n}", "ipopt", {"x": z, "f": f(z, ca.MX(0, 1))}, options)

    def problem(self) -> FitProblem:
        if self._problem is None:
            raise RuntimeError("solver called without a problem")  # a bug here, never the user's data
        return self._problem

    def solve(self, problem: FitProblem, z0: Array, lower: Array, upper: Array) -> SolverRun:
        self._problem = problem
        started = time.perf_counter()
        self._iterations.begin(self._past)
        try:
            out = self.nlp(x0=z0, lbx=lower, ubx=upper)
        finally:
            self._problem = None
        cancellation.check()  # stopped by the iteration callback (or cancelled just after): no result
        stats = self.nlp.stats()
        self._past = [*self._past[-(PAST_SOLVES - 1) :], int(stats.get("iter_count", 0))]
        return SolverRun(
            z=np.asarray(out["x"], dtype=float).reshape(-1),
            status=str(stats.get("return_status", "unknown")),
            success=bool(stats.get("success", False)),
            iterations=int(stats.get("iter_count", -1)),
            seconds=time.perf_counter() - started,
            objective=float(out["f"]),
        )


@dataclass(frozen=True)
class SolverRun:
    """One solver's run (IPOPT's, the trust-region finish's, or the two in turn): where it ended (`z`) and how.
    The result reports their sum as a `SolverReport`."""

    z: Array
    status: str
    success: bool
    iterations: int
    seconds: float
    objective: float


FINISHED_BY = "trust-region finish: "
"""How the status of a run that the trust-region finish ended begins (`pipeline._run`)."""


def solver_report(runs: Sequence[SolverRun], *, evaluations: int, polish_steps: int) -> SolverReport:
    """A fit's runs, in order, as its result reports them: iterations and seconds summed, the last run's status
    and objective, a success only if every run succeeded."""
    return SolverReport(
        name="ipopt+trust-region" if any(r.status.startswith(FINISHED_BY) for r in runs) else "ipopt",
        status=runs[-1].status,
        success=all(r.success for r in runs),
        iterations=sum(r.iterations for r in runs),
        seconds=sum(r.seconds for r in runs),
        objective=runs[-1].objective,
        evaluations=evaluations,
        polish_steps=polish_steps,
    )


class SolverPool:
    """Idle solvers by (n, iteration limit); a solver serves one campaign at a time, so threads never share one.

    Each new solver counts as an "ipopt_solver" build of the owning runtime.
    """

    def __init__(self, runtime: Runtime) -> None:
        self._runtime = runtime
        self._idle: dict[tuple[int, int], list[_Solver]] = {}
        self._lock = threading.Lock()

    def solve(self, problem: FitProblem, z0: Array, lower: Array, upper: Array, max_iter: int = 100) -> SolverRun:
        solver = self._take(problem.n_free, max_iter)
        try:
            return solver.solve(problem, z0, lower, upper)
        finally:
            self._give(solver, max_iter)

    def prepare(self, n: int, max_iter: int = 100) -> None:
        """Have one idle solver for n unknowns ready (warm-up)."""
        self._give(self._take(n, max_iter), max_iter)

    def _take(self, n: int, max_iter: int) -> _Solver:
        with self._lock:
            idle = self._idle.setdefault((n, max_iter), [])
            if idle:
                return idle.pop()
        started = time.perf_counter()
        solver = _Solver(n, max_iter)
        self._runtime.count("ipopt_solver", time.perf_counter() - started)
        return solver

    def _give(self, solver: _Solver, max_iter: int) -> None:
        with self._lock:
            self._idle.setdefault((solver.n, max_iter), []).append(solver)


def solver_pool(runtime: Runtime) -> SolverPool:
    """The runtime's pool of identification solvers."""
    return runtime.artefact("ipopt_pool", None, lambda: SolverPool(runtime))
