"""Identification over a tree: every tool's records and the relative ones in one least-squares problem over the
tree's global parameters.

The pieces are the chain's: the instrument frame registered in closed form first (`rigid_fit` of the nominal
tools' positions onto the measured ones, so the solve starts within the geometric errors); the weighted,
column-scaled Jacobian (rows in σ, columns in tolerances) and the identifiable subset by QR with column pivoting
(`analyse_identifiability`); the solve on the standardised unknowns by MINPACK's Levenberg–Marquardt with
Jacobian column scaling, as the chain's trust-region finish (`models.identification.trust_region`), on the
exact Jacobian; the a-posteriori covariance and its χ² test (`models.identification.statistics`).

What the tree adds: a shared stage's parameters are one column gathered from every chain through it, so the
records of both arms see the waist; `seen_by` says, per estimated parameter, which record groups move it.
Relative records alone do not see the base (the instrument's frame cancels): it is then held, named.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.optimize
from numpy.typing import NDArray

from models._types import Array
from models.engine.runtime import Registry, default_registry
from models.errors import InvalidInput, TooFewMeasurements
from models.identifiability import Identifiability, analyse_identifiability
from models.identification.registration import rigid_fit
from models.identification.statistics import Covariance, covariance
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from models.tree.records import ToolRecords
from models.tree.tree import RobotTree

SEEN_RTOL = 1e-6
"""A record group sees a parameter when its standardised column's norm exceeds this fraction of the largest
column's: exact zeros (another arm's link) sit at 0, real sensitivities many orders above."""


@dataclass(frozen=True)
class TreeProblem:
    """The standardised least squares: unknowns z (tolerances) on the `free` global parameters."""

    tree: RobotTree
    groups: tuple[ToolRecords, ...]
    noise: NoiseModel
    start: Array
    free: NDArray[np.intp]
    registry: Registry

    def theta(self, z: Array) -> Array:
        theta = self.start.copy()
        theta[self.free] += self.tree.parameters.scales[self.free] * z
        return theta

    def evaluate(self, theta: Array) -> tuple[Array, Array]:
        """(residuals in σ, (rows, n_params) Jacobian in σ per tolerance) over every group, at `theta`."""
        scales = self.tree.parameters.scales
        res, jac = [], []
        for group in self.groups:
            r, j = group.residuals(group.model(self.tree, theta, self.registry))
            assert j is not None
            w = group.weights(self.noise)
            res.append((r * w).reshape(-1))
            jac.append((j * w[None, :, None] * scales).reshape(-1, self.tree.n_params))
        return np.concatenate(res), np.vstack(jac)


@dataclass(frozen=True)
class TreeFit:
    """The tree's parameters from its records, and what the fit says about itself."""

    parameters: Array
    """Global, at the solution (internal units)."""
    start: Array
    """After the closed-form registration of the base."""
    estimated: tuple[int, ...]
    """Global indices estimated."""
    identifiability: Identifiability
    std_errors: Array
    """Per global parameter (internal units); NaN for those held."""
    parameter_covariance: Array
    """Of the estimated parameters (`estimated` order), internal units."""
    statistics: Covariance
    seen_by: dict[str, tuple[str, ...]]
    """Estimated parameter name -> the record groups (`ToolRecords.label`) whose rows it moves."""
    rms_mm: dict[str, float]
    """Per record group: RMS position residual at the solution, mm."""
    evaluations: int
    seconds: float

    @property
    def unidentifiable(self) -> tuple[str, ...]:
        return self.identifiability.unidentifiable_names


def identify_tree(
    tree: RobotTree,
    groups: Sequence[ToolRecords],
    *,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    registry: Registry | None = None,
) -> TreeFit:
    """The tree's global parameters from `groups` (see the module docstring); internal units throughout."""
    started = time.perf_counter()
    noise, registry = noise or NoiseModel(), registry or default_registry()
    checked = tuple(g.checked(tree, f"records[{k}]") for k, g in enumerate(groups))
    if not checked:
        raise InvalidInput("identification needs at least one group of records", field="records")
    theta0 = tree.parameters.nominal if nominal is None else tree.parameters.vector(nominal)
    start = registered_start(tree, checked, theta0, registry)
    everything = TreeProblem(tree, checked, noise, start, np.arange(tree.n_params), registry)
    _, scaled = everything.evaluate(start)
    ident = analyse_identifiability(scaled, tree.parameters)
    free = np.array(ident.identifiable, dtype=np.intp)
    if scaled.shape[0] <= free.size:
        raise TooFewMeasurements(
            f"{scaled.shape[0]} equations cannot determine the {free.size} parameters these records see and "
            "leave one for the noise: measure more poses",
            needed=int(free.size + 1),
            got=int(scaled.shape[0]),
            missing=int(free.size + 1 - scaled.shape[0]),
            kind="equations",
        )
    problem = TreeProblem(tree, checked, noise, start, free, registry)
    counter = [0]

    def residuals(z: Array) -> Array:
        counter[0] += 1
        return problem.evaluate(problem.theta(z))[0]

    def jacobian(z: Array) -> Array:
        return problem.evaluate(problem.theta(z))[1][:, free]

    # The chain's finish (trust_region.py): MINPACK's LM with Jacobian column scaling, tolerances at round-off.
    fit = scipy.optimize.least_squares(
        residuals, np.zeros(free.size), jac=jacobian, method="lm", x_scale="jac", ftol=1e-12, xtol=1e-10, gtol=1e-10
    )
    theta = problem.theta(np.asarray(fit.x, dtype=float))
    r, j = problem.evaluate(theta)
    return _fit(problem, theta, r, j, ident, evaluations=counter[0], seconds=time.perf_counter() - started)


def restated_fit(
    tree: RobotTree,
    groups: Sequence[ToolRecords],
    theta: Array,
    estimated: Sequence[int],
    *,
    noise: NoiseModel | None = None,
    start: Array | None = None,
    registry: Registry | None = None,
) -> TreeFit:
    """The fit `identify_tree` returned, from what it stored: its records, its solution `theta` and its
    `estimated` parameters (global indices), without solving again. Its covariance, standard errors and residuals
    are evaluated at `theta` as the fit's were (a report draws them long after the fit)."""
    noise, registry = noise or NoiseModel(), registry or default_registry()
    checked = tuple(g.checked(tree, f"records[{k}]") for k, g in enumerate(groups))
    free = np.array(estimated, dtype=np.intp)
    problem = TreeProblem(tree, checked, noise, theta if start is None else start, free, registry)
    r, j = problem.evaluate(theta)
    ident = analyse_identifiability(j, tree.parameters)
    return _fit(problem, theta, r, j, ident, evaluations=0, seconds=0.0)


def _fit(
    problem: TreeProblem,
    theta: Array,
    r: Array,
    j: Array,
    ident: Identifiability,
    *,
    evaluations: int,
    seconds: float,
) -> TreeFit:
    """The result at the solution: covariance (tolerances -> internal units), standard errors, who sees what."""
    tree, free = problem.tree, problem.free
    stats = covariance(j[:, free], r)
    scales = tree.parameters.scales[free]
    cov = stats.z * np.outer(scales, scales)
    std = np.full(tree.n_params, np.nan)
    std[free] = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    rms: dict[str, float] = {}
    seen: dict[str, list[str]] = {tree.parameters.names[i]: [] for i in free}
    at = 0
    column_max = float(np.linalg.norm(j[:, free], axis=0).max())
    for group in problem.groups:
        rows = slice(at, at + group.size * group.rows)
        block = r[rows].reshape(group.size, group.rows) / group.weights(problem.noise)
        rms[group.label] = float(np.sqrt(np.mean(np.sum(block[:, :3] ** 2, axis=1))))
        for i in free[np.linalg.norm(j[rows][:, free], axis=0) > SEEN_RTOL * column_max]:
            seen[tree.parameters.names[i]].append(group.label)
        at = rows.stop
    return TreeFit(
        parameters=theta,
        start=problem.start,
        estimated=tuple(int(i) for i in free),
        identifiability=ident,
        std_errors=std,
        parameter_covariance=cov,
        statistics=stats,
        seen_by={name: tuple(labels) for name, labels in seen.items()},
        rms_mm=rms,
        evaluations=evaluations,
        seconds=seconds,
    )


def registered_start(tree: RobotTree, groups: tuple[ToolRecords, ...], theta: Array, registry: Registry) -> Array:
    """`theta` with its base moved by the rigid fit of the nominal tools' positions onto the measured ones (the
    instrument's frame, in closed form); unchanged when no group is in the instrument's frame."""
    absolute = [g for g in groups if g.frame is None]
    if not absolute:
        return theta.copy()
    model = np.vstack([g.model(tree, theta, registry, jacobian=False).positions for g in absolute])
    fit = rigid_fit(model, np.vstack([g.positions for g in absolute]))
    out = theta.copy()
    rotation = fit.rotation @ rotvec_to_matrix_np(theta[3:6])
    out[:6] = np.r_[fit.rotation @ theta[:3] + fit.translation, matrix_to_rotvec_np(rotation)]
    return out
