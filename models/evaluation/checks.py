"""The quick check: a few records against the current version, and whether the robot is still the one calibrated.

The records' residuals against the version's forward kinematics (after the instrument frame is registered in
closed form, or not when the check is measured from the calibration's own tracker setup) are whitened by their
predicted covariance

    V = diag(σ²) + J Σ Jᵀ

— the instrument's noise plus the version's parameter covariance `Σ` propagated to these poses by the
identification Jacobian `J` — and the registration's six rigid-motion columns `G` are projected out in that
metric (generalised least squares). For an unchanged robot the statistic χ² = r̃ᵀ(I − Q Qᵀ)r̃ follows χ² with
rows − rank(G) degrees of freedom, so `fine` below its 1 − α quantile is wrong (a false alarm) in a fraction α
of checks.

Above it, each candidate explanation — every single parameter and every group (the table's groups and each
link, leg, base or tool by its name's prefix) — is fitted in the same metric: its least-squares change Δ, the
reduction of χ² it gives (a likelihood-ratio statistic, χ²(k) under no change) and the χ² left (χ² with k fewer
degrees of freedom). A candidate *explains* the check when (1) its reduction is significant at α, (2) what is
left is below its own 1 − α quantile, (3) it leaves at least one degree of freedom and (4) the change is large:
some |Δᵢ| at least `change_sigmas` times its standard error — in the metric V, so that error holds the version's
own uncertainty of the parameter (and of those correlated with it) beside the noise. The verdict is then

- `changed` with the explanation of fewest parameters (ties: the smallest χ² left): re-fit those parameters;
- `drifted` when none explains it and χ²/dof ≤ `drift_ratio` (the misfit is spread and moderate): calibrate;
- `changed` without an explanation above that ratio (a crash, several things at once): calibrate.

Internal units (mm, rad).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import scipy.linalg
import scipy.optimize
import scipy.special

from models._types import Array
from models.campaign import Campaign
from models.description.parameters import ParameterTable
from models.description.robot import RobotDescription
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput, WrongShape
from models.identification.reference_fit import ReferenceProblem
from models.identification.reference_fit import check_version as reference_check
from models.identification.registration import rigid_fit
from models.kinematics import forward_kinematics
from models.measurements.references import ReferenceRecords
from models.noise import NoiseModel
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np

MIN_RECORDS = 3
"""Fewer records fix no instrument frame, and leave a test without power."""
RANK_RTOL = 1e-7
"""A candidate's projected column below this fraction of its whitened norm is absorbed by the registration."""
MIN_REFIT_POSES = 8
CALIBRATION_POSES = 60


class Verdict(StrEnum):
    FINE = "fine"
    DRIFTED = "drifted"
    CHANGED = "changed"


class CheckAction(StrEnum):
    NONE = "none"
    REFIT = "refit"
    CALIBRATE = "calibrate"


@dataclass(frozen=True)
class CheckOptions:
    alpha: float = 0.01
    """The false-alarm rate: the probability that an unchanged robot is not called `fine`."""
    register: bool = True
    """Fit the instrument frame first; False for a check from the calibration's tracker setup (its base holds
    the instrument frame, with its uncertainty in the covariance)."""
    change_sigmas: float = 5.0
    """How many of its standard errors (in the metric V) a change must be to explain the check."""
    drift_ratio: float = 25.0
    """χ²/dof up to which an unexplained misfit is drift: residuals up to five times their predicted σ (RMS);
    beyond, something broke."""
    calibration_poses: int = CALIBRATION_POSES
    """The poses a full calibration is recommended with (the robot's last campaign's, where the caller knows)."""

    def __post_init__(self) -> None:
        if not 0.0 < self.alpha < 0.5:
            raise InvalidInput(f"alpha must lie in (0, 0.5), got {self.alpha}", field="alpha", value=self.alpha)
        if self.change_sigmas <= 0 or self.drift_ratio <= 1:
            raise InvalidInput("change_sigmas must be > 0 and drift_ratio > 1", field="change_sigmas")


@dataclass(frozen=True)
class Explanation:
    name: str
    """A parameter's name or a group's."""
    parameters: tuple[int, ...]
    """Table indices of the parameters whose change it fits."""
    change: Array
    """The fitted change of each, internal units."""
    std_error: Array
    """Of each change, from the check's records."""
    prior_sigma: Array
    """Each parameter's σ in the version (0 where the version holds it without one)."""
    chi2: float
    """χ² left after the change."""
    dof: int
    reduction: float
    p_value: float
    """Of the reduction, were nothing changed (χ² with `rank` degrees of freedom)."""
    rank: int
    explains: bool


@dataclass(frozen=True)
class Recommendation:
    action: CheckAction
    parameters: tuple[str, ...]
    """What to re-fit (REFIT); empty otherwise."""
    poses: int
    """Designed poses to measure: for the re-fit, or the full calibration; 0 for nothing."""


@dataclass(frozen=True)
class CheckResult:
    verdict: Verdict
    chi2: float
    dof: int
    threshold: float
    """The χ²(dof) quantile at 1 − α."""
    p_value: float
    alpha: float
    registered: bool
    position_mm: Array
    """(N,) |measured − predicted| per record after the registration."""
    predicted_mm: Array
    """(N,) the predicted 1-σ size of each record's position error, √trace of its 3 × 3 block of V."""
    explanation: Explanation | None
    alternatives: tuple[Explanation, ...]
    """The next candidates (at most 3): those that explain it as the rule ranks them, then the rest by χ² left."""
    recommendation: Recommendation
    seconds: float


def version_covariance(
    table: ParameterTable, std_errors: Array | None, names: list[str] | None = None, correlation: Array | None = None
) -> Array:
    """(P, P) the version's parameter covariance in table order: std errors (NaN or None: 0, a parameter held),
    with the calibration's correlation matrix over `names` where it exists."""
    p = len(table)
    sd = np.zeros(p) if std_errors is None else np.nan_to_num(np.asarray(std_errors, dtype=float), nan=0.0)
    if sd.shape != (p,):
        raise WrongShape(
            f"expected {p} std errors, got {sd.shape}", field="std_errors", expected=[p], got=list(sd.shape)
        )
    cov = np.diag(sd**2)
    if names is not None and correlation is not None:
        idx = np.array([table.index[n] for n in names], dtype=int)
        r = np.asarray(correlation, dtype=float)
        cov[np.ix_(idx, idx)] = r * np.outer(sd[idx], sd[idx])
    return cov


def candidate_groups(table: ParameterTable) -> dict[str, tuple[int, ...]]:
    """The explanations tried beside single parameters: the table's groups and each name prefix (link3, tool)."""
    prefixes: dict[str, list[int]] = {}
    for i, name in enumerate(table.names):
        prefix = name.split(".", 1)[0]
        if prefix != name:
            prefixes.setdefault(prefix, []).append(i)
    groups = dict(table.groups)
    for prefix, index in prefixes.items():
        groups.setdefault(prefix, tuple(index))  # `tool`, `base`: a table group already
    return {g: ix for g, ix in groups.items() if ix}


@dataclass(frozen=True)
class _Whitened:
    r: Array
    """Whitened residual with the registration projected out."""
    jac: Array
    """Whitened, projected parameter Jacobian (rows, P)."""
    norms: Array
    """Column norms of the whitened Jacobian before the projection."""
    dof: int


@single_threaded_blas
def check_version(
    desc: RobotDescription,
    params: Array,
    covariance: Array,
    campaign: Campaign,
    *,
    noise: NoiseModel | None = None,
    options: CheckOptions | None = None,
    runtime: Runtime | None = None,
) -> CheckResult:
    """The check of `campaign` (tracker records) against the version `params` with parameter covariance
    `covariance` (P × P, table order; `version_covariance`)."""
    started = time.perf_counter()
    options, noise = options or CheckOptions(), noise or NoiseModel()
    _checked(desc, covariance, campaign.size)
    residual, jac, nuisance, sigma, position_mm = _linearised(
        desc, params, campaign, noise, register=options.register, runtime=runtime
    )
    v = np.diag(sigma**2) + jac @ covariance @ jac.T
    rows = 3 if campaign.quaternions is None else 6
    predicted = np.sqrt(np.einsum("nii->n", _blocks(v, rows)[:, :3, :3]))
    w = _whiten(v, residual, jac, nuisance)
    return _result(
        desc,
        w,
        covariance,
        options,
        position_mm=position_mm,
        predicted_mm=predicted,
        rows=rows,
        started=started,
        registered=options.register,
    )


def _result(
    desc: RobotDescription,
    w: _Whitened,
    covariance: Array,
    options: CheckOptions,
    *,
    position_mm: Array,
    predicted_mm: Array,
    rows: int,
    started: float,
    registered: bool = True,
) -> CheckResult:
    """The test, the explanations, the verdict and the recommendation of whitened, projected residuals."""
    chi2 = float(w.r @ w.r)
    threshold = float(scipy.special.chdtri(w.dof, options.alpha))
    explanations = _explanations(desc.parameters, w, covariance, options)
    verdict, best = _verdict(chi2, w.dof, threshold, explanations, options)
    # As the rule ranks them: those that explain it, fewest parameters first (a near twin of the best: a leg's
    # offset beside its joint along the leg), then the rest by the χ² they leave.
    others = sorted((e for e in explanations if e is not best), key=lambda e: (not e.explains, e.rank, e.chi2))[:3]
    return CheckResult(
        verdict=verdict,
        chi2=chi2,
        dof=w.dof,
        threshold=threshold,
        p_value=float(scipy.special.chdtrc(w.dof, chi2)),
        alpha=options.alpha,
        registered=registered,
        position_mm=position_mm,
        predicted_mm=predicted_mm,
        explanation=best,
        alternatives=tuple(others) if verdict is not Verdict.FINE else (),
        recommendation=_recommendation(desc, verdict, best, rows, options),
        seconds=time.perf_counter() - started,
    )


def _checked(desc: RobotDescription, covariance: Array, records: int) -> None:
    p = desc.n_params
    if covariance.shape != (p, p):
        raise WrongShape(
            f"expected a ({p}, {p}) covariance", field="covariance", expected=[p, p], got=list(covariance.shape)
        )
    if records < MIN_RECORDS:
        raise InvalidInput(
            f"a check needs at least {MIN_RECORDS} records, got {records}", field="measurements", min=MIN_RECORDS
        )


def _blocks(v: Array, rows: int) -> Array:
    n = v.shape[0] // rows
    return np.stack([v[k * rows : (k + 1) * rows, k * rows : (k + 1) * rows] for k in range(n)])


def _linearised(
    desc: RobotDescription,
    params: Array,
    campaign: Campaign,
    noise: NoiseModel,
    *,
    register: bool,
    runtime: Runtime | None,
) -> tuple[Array, Array, Array, Array, Array]:
    """Residual rows, their parameter Jacobian, the registration's columns (none without it), each row's σ and
    the per-record position errors, all in the instrument frame."""
    campaign.condition_inputs(desc)
    fk = forward_kinematics(  # its joints were checked as readings when the campaign was made (make_campaign)
        desc,
        campaign.joints,
        params,
        jacobian=True,
        check_ranges=False,
        conditions=campaign.conditions,
        runtime=runtime_for(desc, runtime),
    )
    positions, rotations, jac = fk.positions, fk.rotations, fk.jacobians
    if register:
        fit = rigid_fit(positions, campaign.positions)
        positions = fit.apply(positions)
        rotations = np.einsum("ij,njk->nik", fit.rotation, rotations)
        jac = np.concatenate(
            [np.einsum("ij,njp->nip", fit.rotation, jac[:, :3]), np.einsum("ij,njp->nip", fit.rotation, jac[:, 3:])],
            axis=1,
        )
    n = campaign.size
    error = campaign.positions - positions
    sigma_p = np.full(n, noise.position_mm) if campaign.sigma_mm is None else campaign.sigma_mm
    frame = frame_columns(positions)
    if campaign.quaternions is None:
        res, jrows, grows = error, jac[:, :3], frame[:, :3]
        sigma = np.repeat(sigma_p, 3)
    else:
        angle = matrix_to_rotvec_np(campaign.rotations @ np.transpose(rotations, (0, 2, 1)))
        res, jrows, grows = np.concatenate([error, angle], axis=1), jac, frame
        sigma = np.concatenate([np.repeat(sigma_p[:, None], 3, axis=1), np.full((n, 3), noise.orientation_rad)], axis=1)
    k = res.shape[1]
    nuisance = grows.reshape(n * k, 6) if register else np.zeros((n * k, 0))
    return res.reshape(-1), jrows.reshape(n * k, -1), nuisance, sigma.reshape(-1), np.linalg.norm(error, axis=1)


def frame_columns(positions: Array) -> Array:
    """(N, 6, 6) the registration's columns at each predicted pose: a small shift τ and rotation φ of the
    instrument frame move a point by τ + φ × p (rows 0-2) and an orientation by φ (rows 3-5)."""
    n = positions.shape[0]
    frame = np.zeros((n, 6, 6))
    frame[:, :3, :3] = np.eye(3)
    frame[:, :3, 3:] = -_skew(positions)
    frame[:, 3:, 3:] = np.eye(3)
    return frame


def _skew(p: Array) -> Array:
    out = np.zeros((p.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2], out[:, 1, 2] = -p[:, 2], p[:, 1], -p[:, 0]
    return out - np.transpose(out, (0, 2, 1))


def _whiten(v: Array, residual: Array, jac: Array, nuisance: Array) -> _Whitened:
    chol = np.linalg.cholesky(v)

    def solve(x: Array) -> Array:
        return np.asarray(scipy.linalg.solve_triangular(chol, x, lower=True), dtype=float)

    r, j = solve(residual), solve(jac)
    norms = np.linalg.norm(j, axis=0)
    dof = residual.size
    if nuisance.shape[1]:
        q, s, _ = np.linalg.svd(solve(nuisance), full_matrices=False)
        q = q[:, s > RANK_RTOL * s[0]]
        r, j, dof = r - q @ (q.T @ r), j - q @ (q.T @ j), dof - q.shape[1]
    return _Whitened(r, j, norms, dof)


def _explanations(table: ParameterTable, w: _Whitened, covariance: Array, options: CheckOptions) -> list[Explanation]:
    chi2 = float(w.r @ w.r)
    prior = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    # A parameter the version holds without an uncertainty (not identifiable from its campaign) is confounded
    # with those it estimated: alone it is no explanation of its own, though its group may be.
    singles = np.flatnonzero(prior > 0) if np.any(prior > 0) else np.arange(len(table))
    candidates: list[tuple[str, tuple[int, ...]]] = [(table.names[i], (int(i),)) for i in singles]
    candidates += [(g, ix) for g, ix in candidate_groups(table).items() if len(ix) > 1]
    out = []
    for name, index in candidates:
        a = w.jac[:, list(index)]
        u, s, vt = np.linalg.svd(a, full_matrices=False)
        keep = s > RANK_RTOL * max(float(w.norms[list(index)].max()), 1e-300)
        rank = int(keep.sum())
        if rank == 0 or rank >= w.dof:
            continue
        u, s, vt = u[:, keep], s[keep], vt[keep]
        coef = u.T @ w.r
        change = vt.T @ (coef / s)
        std = np.sqrt(np.einsum("ki,k->i", vt**2, 1.0 / s**2))
        reduction = float(coef @ coef)
        dof = w.dof - rank
        p_value = float(scipy.special.chdtrc(rank, reduction))
        # Large: some change at least `change_sigmas` of its standard error. That error is the check's, in the
        # metric V, so it holds the version's own uncertainty of the parameter and of everything correlated with
        # it: a parameter's marginal σ alone would ask too much of one strongly correlated (a leg's offset).
        ratio = np.divide(np.abs(change), std, out=np.zeros_like(std), where=std > 0)
        large = bool(ratio.max() >= options.change_sigmas)
        left = max(chi2 - reduction, 0.0)
        explains = bool(p_value < options.alpha and left <= scipy.special.chdtri(dof, options.alpha) and large)
        out.append(
            Explanation(name, index, change, std, prior[list(index)], left, dof, reduction, p_value, rank, explains)
        )
    return out


def _verdict(
    chi2: float, dof: int, threshold: float, explanations: list[Explanation], options: CheckOptions
) -> tuple[Verdict, Explanation | None]:
    if chi2 <= threshold:
        return Verdict.FINE, None
    explaining = [e for e in explanations if e.explains]
    if explaining:
        return Verdict.CHANGED, min(explaining, key=lambda e: (e.rank, e.chi2))
    return (Verdict.DRIFTED if chi2 / dof <= options.drift_ratio else Verdict.CHANGED), None


def _recommendation(
    desc: RobotDescription, verdict: Verdict, best: Explanation | None, rows: int, options: CheckOptions
) -> Recommendation:
    if verdict is Verdict.FINE:
        return Recommendation(CheckAction.NONE, (), 0)
    if best is None:
        return Recommendation(CheckAction.CALIBRATE, (), options.calibration_poses)
    # Twice the poses that determine the changed parameters with the instrument frame, and at least 8.
    unknowns = best.rank + (6 if options.register else 0)
    poses = max(MIN_REFIT_POSES, 2 * math.ceil(unknowns / rows))
    return Recommendation(CheckAction.REFIT, tuple(desc.parameters.names[i] for i in best.parameters), poses)


POWER = 0.95
"""The detection probability `detectable_changes` sizes changes for."""


@single_threaded_blas
def detectable_changes(
    desc: RobotDescription,
    params: Array,
    covariance: Array,
    joints: Array,
    parameters: tuple[int, ...],
    *,
    position_only: bool = True,
    noise: NoiseModel | None = None,
    options: CheckOptions | None = None,
    runtime: Runtime | None = None,
) -> Array:
    """For each of `parameters`, the change of it alone that a check at `joints` flags with probability POWER
    (internal units; inf where the check cannot see it): under that change the statistic is non-central χ²
    with non-centrality Δ² ‖ĵᵢ‖², ĵᵢ the parameter's whitened column with the registration projected out."""
    options, noise = options or CheckOptions(), noise or NoiseModel()
    rt = runtime_for(desc, runtime)
    fk = forward_kinematics(desc, joints, params, runtime=rt)
    quaternions = None if position_only else matrix_to_quaternion(fk.rotations)
    exact = Campaign(np.asarray(joints, dtype=float), fk.positions, quaternions)
    _, jac, nuisance, sigma, _ = _linearised(desc, params, exact, noise, register=options.register, runtime=rt)
    w = _whiten(np.diag(sigma**2) + jac @ covariance @ jac.T, np.zeros(jac.shape[0]), jac, nuisance)
    threshold = scipy.special.chdtri(w.dof, options.alpha)

    def power(lam: float) -> float:
        return 1.0 - float(scipy.special.chndtr(threshold, w.dof, lam)) - POWER

    lam = float(scipy.optimize.brentq(power, 1e-9, 1e4))
    seen = np.linalg.norm(w.jac[:, list(parameters)], axis=0)
    visible = seen > RANK_RTOL * np.maximum(w.norms[list(parameters)], 1e-300)
    return np.where(visible, np.sqrt(lam) / np.where(visible, seen, 1.0), np.inf)


@single_threaded_blas
def check_references(
    desc: RobotDescription,
    params: Array,
    covariance: Array,
    groups: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel | None = None,
    options: CheckOptions | None = None,
    runtime: Runtime | None = None,
) -> CheckResult:
    """The check of reference records (distance, point, plane: `models.measurements.references`) against the
    version: the references' own unknowns (an anchor's place, a bar's length where unknown, a plane) take the
    registration's part, fitted with the robot held and projected out in the metric V like the frame's
    columns; `options.register` does not apply (the references fix their own frame, or none)."""
    started = time.perf_counter()
    options, noise = options or CheckOptions(), noise or NoiseModel()
    p, records = desc.n_params, sum(g.size for g in groups)
    _checked(desc, covariance, records)
    rt = runtime_for(desc, runtime)
    placed = reference_check(desc, groups, params, noise=noise, runtime=rt)
    u = np.concatenate([np.asarray(x, dtype=float) for x in placed.unknowns])
    every = np.arange(p, dtype=np.intp)
    problem = ReferenceProblem(desc, rt, placed.references, noise, params, every, u, np.ones(u.size))
    evaluation = problem.evaluate(np.zeros(problem.n_free))
    if evaluation is None:
        raise InvalidInput("the version cannot evaluate these records (a non-finite residual)", field="measurements")
    # The problem's rows are already divided by each record's σ, its robot columns scaled by the tolerances.
    residual = evaluation.residuals[:, 0]
    jac = evaluation.jacobian[:, :p] / desc.parameters.scales
    v = np.eye(residual.size) + jac @ covariance @ jac.T
    w = _whiten(v, residual, jac, evaluation.jacobian[:, p:])
    rows = [g.reference.traits.rows for g in placed.references for _ in range(g.size)]
    sigma = np.concatenate([1.0 / np.asarray(x) for x in problem.weights])
    edges = np.cumsum([0, *rows])
    diagonal = np.diag(v)
    predicted = np.array([sigma[k] * np.sqrt(diagonal[edges[k] : edges[k + 1]].sum()) for k in range(records)])
    return _result(
        desc,
        w,
        covariance,
        options,
        position_mm=placed.errors_mm,
        predicted_mm=predicted,
        rows=max(rows),
        started=started,
    )
