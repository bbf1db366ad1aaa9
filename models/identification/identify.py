"""Measured poses → the robot's real parameters.

Steps: validate and register the instrument frame in closed form; find the
identifiable subset from the weighted, column-scaled Jacobian (the same
analysis pose design uses); solve the weighted least-squares problem with
IPOPT (optionally robust, then without the flagged outliers); report the
a-posteriori statistics, re-check identifiability at the solution, and
predict the TCP accuracy the result gives over the workspace.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from models.blas import single_threaded_blas
from models.campaign import Campaign
from models.errors import InvalidInput, NonFiniteValue, NotIdentifiable, TooFewMeasurements, UnreachablePose
from models.function_cache import functions_for
from models.hybrid import RobotDescription
from models.identifiability import (
    Identifiability,
    NoiseModel,
    analyse_identifiability,
    measurement_rows,
    scaled_jacobian,
)
from models.identification.ipopt_solver import SOLVERS, SolveReport
from models.identification.options import IdentificationOptions, RobustLoss
from models.identification.registration import registered_base, rigid_fit
from models.identification.residuals import CampaignProblem, Loss
from models.identification.result import (
    IdentificationResult,
    Outlier,
    PredictedAccuracy,
    ResidualSummary,
    SolverReport,
)
from models.identification.statistics import (
    PoseErrors,
    correlated_pairs,
    covariance,
    outlier_threshold,
    tcp_accuracy,
)
from models.kinematics import CLOSURE_TOLERANCE_MM, Array, forward_kinematics, pose_batch, solve_platforms
from models.workspace import sample_workspace

INCONSISTENT_SIGMA = 100.0
"""A fit whose RMS standardised residual exceeds this cannot come from this robot with the stated noise."""
WORKSPACE_SEED = 20_090_101
STRUCTURAL_POSES = 60
POLISH_STEPS = 4
POLISH_DECREMENT = 1e-6
"""Gauss–Newton polishing stops when the next step would lower Σr² by less than this (in σ²)."""


@single_threaded_blas
def identify(
    desc: RobotDescription,
    campaign: Campaign,
    *,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    options: IdentificationOptions | None = None,
) -> IdentificationResult:
    """Identify the parameters of `desc` from `campaign` (internal units throughout)."""
    started = time.perf_counter()
    noise = noise or NoiseModel()
    options = options or IdentificationOptions()
    if not (
        noise.position_mm > 0
        and noise.orientation_rad > 0
        and np.isfinite([noise.position_mm, noise.orientation_rad]).all()
    ):
        raise InvalidInput("the instrument noise must be positive and finite (σ position in mm, σ orientation)")
    table = desc.parameters
    theta_nom = table.nominal if nominal is None else table.vector(nominal)
    if not np.all(np.isfinite(theta_nom)):
        raise NonFiniteValue("the nominal parameters contain non-finite numbers")
    candidates = table.indices(options.estimate)
    rows = measurement_rows(campaign.position_only)
    _check_enough(desc, campaign, candidates)

    fk = forward_kinematics(desc, campaign.joints, theta_nom)
    base = set(table.groups["base"])
    notes: list[str] = []
    if base <= set(candidates):
        fit = rigid_fit(fk.positions, campaign.positions)
        theta_start = registered_base(desc, theta_nom, fit)
    else:
        theta_start = theta_nom
        notes.append("the base (instrument frame) is not estimated: the given base is taken as exact")

    start = forward_kinematics(desc, campaign.joints, theta_start, jacobian=True, seeds=fk.platforms)
    assert start.jacobians is not None
    scaled = scaled_jacobian(start.jacobians, table, noise, position_only=campaign.position_only)
    ident = _identifiable_subset(desc, scaled, candidates, campaign.position_only, notes)
    if not ident.identifiable:
        raise NotIdentifiable("the measurements determine none of the requested parameters")
    free = np.array(ident.identifiable)

    loss = Loss(options.robust, options.robust_scale)
    problem = CampaignProblem(
        desc, functions_for(desc), campaign, noise, theta_start, free, loss, platforms=start.platforms.copy()
    )
    lower, upper = _bounds(problem, options)
    z0 = np.clip(np.zeros(free.size), lower, upper)
    first = SOLVERS.solve(problem, z0, lower, upper, options.max_iterations)
    evaluations = 0  # of the problems already left behind
    reports = [first]

    ev = problem.evaluate(first.z)
    outliers, excluded = _outliers(problem, first.z, options, rows)
    if ev is not None and excluded.size:
        evaluations += problem.evaluations
        keep = np.setdiff1d(np.arange(campaign.size), excluded)
        problem = CampaignProblem(
            desc, problem.functions, campaign, noise, theta_start, free, Loss(), keep, problem.platforms
        )
        reports.append(SOLVERS.solve(problem, first.z, lower, upper, options.max_iterations))
    polished, polish_steps = _polish(problem, reports[-1].z, lower, upper)
    ev = problem.evaluate(polished)
    last = reports[-1]
    solver = SolverReport(
        name="ipopt",
        status=last.status,
        success=all(r.success for r in reports),
        iterations=sum(r.iterations for r in reports),
        seconds=sum(r.seconds for r in reports),
        objective=last.objective,
        evaluations=evaluations + problem.evaluations,
        polish_steps=polish_steps,
    )
    if ev is None:
        return _failed_geometry(
            desc, campaign=campaign, theta_nom=theta_nom, theta_start=theta_start, solver=solver, started=started
        )
    theta = ev.theta

    cov = covariance(ev.jacobian, ev.residuals)
    scales = table.scales[free]
    cov_theta = cov.z * np.outer(scales, scales)
    std = np.full(len(table), np.nan)
    std[free] = np.sqrt(np.diag(cov_theta))

    before = _pose_errors(desc, campaign, theta_start, start.platforms)
    after = _pose_errors(desc, campaign, theta, problem.platforms)
    try:
        final = forward_kinematics(
            desc, campaign.joints, theta, jacobian=True, seeds=problem.platforms, check_ranges=False
        )
    except UnreachablePose:
        return _failed_geometry(
            desc, campaign=campaign, theta_nom=theta_nom, theta_start=theta_start, solver=solver, started=started
        )
    assert final.jacobians is not None
    recheck = analyse_identifiability(
        scaled_jacobian(final.jacobians, table, noise, position_only=campaign.position_only), table, candidates
    )
    if recheck.rank != ident.rank:
        notes.append(
            f"at the solution {recheck.rank} parameters are identifiable (at the start: {ident.rank}); "
            "the estimate used the starting subset"
        )

    status, reason = "succeeded", None
    rms_sigma = math.sqrt(cov.variance_factor) if np.isfinite(cov.variance_factor) else float("nan")
    if not solver.success:
        status, reason = "failed", f"IPOPT did not converge: {solver.status}"
    elif rms_sigma > INCONSISTENT_SIGMA:
        status = "failed"
        reason = (
            f"after the fit the residuals are still {rms_sigma:.0f} σ (RMS): these measurements cannot come from "
            "this robot with the stated noise (check the joint order and units, the robot, and the noise)"
        )
    elif not cov.noise_consistent:
        notes.append(
            f"variance factor {cov.variance_factor:.3g} is outside [{cov.chi2_interval[0]:.3g}, "
            f"{cov.chi2_interval[1]:.3g}]: the stated instrument noise does not match the residuals"
        )

    return IdentificationResult(
        status=status,
        reason=reason,
        table=table,
        parameters=theta,
        nominal=theta_nom,
        start=theta_start,
        estimated=tuple(int(i) for i in free),
        std_errors=std,
        covariance=cov_theta,
        correlated_pairs=correlated_pairs(cov_theta, tuple(table.names[i] for i in free)),
        confounding=ident.confounding,
        rank=ident.rank,
        condition_number=ident.condition_number,
        identifiability_rechecked=recheck.rank == ident.rank,
        residuals_before=ResidualSummary.of(before),
        residuals_after=ResidualSummary.of(after),
        variance_factor=cov.variance_factor,
        dof=cov.dof,
        noise_consistent=cov.noise_consistent,
        outliers=outliers,
        solver=solver,
        predicted_accuracy=predicted_accuracy(desc, theta, free, cov_theta, options.workspace_samples),
        position_only=campaign.position_only,
        measurements=campaign.size,
        seconds=time.perf_counter() - started,
        notes=tuple(notes),
    )


def _polish(problem: CampaignProblem, z: Array, lower: Array, upper: Array) -> tuple[Array, int]:
    """Full Gauss–Newton steps after IPOPT until the next one would lower Σr² by < POLISH_DECREMENT σ².

    IPOPT stops on an absolute gradient test; in a badly conditioned campaign that can leave the weakest
    directions short of the optimum by more than their own uncertainty. The decrement gᵀH⁻¹g is the χ² the next
    step would gain, the test that matters statistically. Skipped when bounds are set (a step may cross one).
    """
    if np.isfinite(lower).any() or np.isfinite(upper).any():
        return z, 0
    z = z.copy()
    steps = 0
    for _ in range(POLISH_STEPS):
        ev = problem.evaluate(z)
        if ev is None:
            break
        try:
            step = np.linalg.solve(ev.hessian, -ev.gradient)
        except np.linalg.LinAlgError:
            break
        if -float(ev.gradient @ step) * ev.residuals.size < POLISH_DECREMENT:
            break
        trial = problem.evaluate(z + step)
        if trial is None or trial.objective > ev.objective * (1 + 1e-12):
            break
        z = z + step
        steps += 1
    return z, steps


@lru_cache(maxsize=64)
def structural_identifiability(
    desc: RobotDescription, candidates: tuple[int, ...], position_only: bool
) -> Identifiability:
    """What rich data could identify on this robot: the analysis on many random poses of the nominal model.

    Exact redundancies are properties of the structure, so the subset chosen here is the one every campaign of
    this robot uses (when its data support it): two calibrations name the same parameters, instead of subsets
    that differ wherever noise breaks a tie between equivalent columns. QR with column pivoting keeps the
    strongest columns, so the chosen parametrisation is also the best conditioned (measured: choosing the
    tool over platform joints instead makes the covariance 250 times worse conditioned).
    """
    joints = sample_workspace(desc, STRUCTURAL_POSES, seed=WORKSPACE_SEED)
    fk = forward_kinematics(desc, joints, jacobian=True)
    assert fk.jacobians is not None
    scaled = scaled_jacobian(fk.jacobians, desc.parameters, NoiseModel(), position_only=position_only)
    return analyse_identifiability(scaled, desc.parameters, candidates)


def minimum_poses(desc: RobotDescription, candidates: tuple[int, ...], position_only: bool) -> tuple[int, int]:
    """(rank the structure allows for these parameters, fewest poses that can determine them and the noise)."""
    rank = structural_identifiability(desc, candidates, position_only).rank
    return rank, math.ceil((rank + 1) / measurement_rows(position_only))


def _identifiable_subset(
    desc: RobotDescription, scaled: Array, candidates: tuple[int, ...], position_only: bool, notes: list[str]
) -> Identifiability:
    """The structural subset if these data determine it; otherwise the data's own (smaller) subset."""
    table = desc.parameters
    structural = structural_identifiability(desc, candidates, position_only)
    own = analyse_identifiability(scaled, table, structural.identifiable)
    if own.rank == structural.rank:
        full = analyse_identifiability(scaled, table, candidates)
        return replace(
            full,
            identifiable=structural.identifiable,
            unidentifiable=structural.unidentifiable,
            confounding=structural.confounding,
        )
    notes.append(
        f"these poses determine only {own.rank} of the {structural.rank} parameters rich data would: the "
        "weakest directions stay at their nominal values (measure more varied poses)"
    )
    return analyse_identifiability(scaled, table, candidates)


def _check_enough(desc: RobotDescription, campaign: Campaign, candidates: tuple[int, ...]) -> None:
    rank, needed = minimum_poses(desc, candidates, campaign.position_only)
    if campaign.size < needed:
        kind = "position-only" if campaign.position_only else "full-pose"
        raise TooFewMeasurements(
            f"{campaign.size} {kind} measurements cannot determine the {rank} identifiable parameters: at least "
            f"{needed} are needed, so measure {needed - campaign.size} more (for a useful accuracy, 3-5 times that)",
            got=campaign.size,
            needed=needed,
            missing=needed - campaign.size,
        )


def _bounds(problem: CampaignProblem, options: IdentificationOptions) -> tuple[Array, Array]:
    table = problem.desc.parameters
    lower = np.full(problem.n_free, -np.inf)
    upper = np.full(problem.n_free, np.inf)
    position = {int(j): k for k, j in enumerate(problem.free)}
    for name, (lo, hi) in options.bounds.items():
        i = table.indices([name])
        if len(i) != 1 or name not in table.index:
            raise InvalidInput(f"bounds are set per parameter, and {name!r} is not a parameter name", name=name)
        if (not (np.isfinite(lo) or np.isfinite(hi)) and lo > hi) or lo > hi:
            raise InvalidInput(f"bounds of {name}: lower {lo} is above upper {hi}", name=name)
        k = position.get(i[0])
        if k is None:
            continue
        start, scale = problem.theta_start[i[0]], problem.scales[k]
        lower[k], upper[k] = (lo - start) / scale, (hi - start) / scale
    return lower, upper


def _outliers(
    problem: CampaignProblem, z: Array, options: IdentificationOptions, rows: int
) -> tuple[tuple[Outlier, ...], NDArray[np.intp]]:
    ev = problem.evaluate(z)
    if ev is None:
        return (), np.empty(0, dtype=np.intp)
    assert problem.active is not None
    stat = np.sum(ev.residuals**2, axis=1)
    threshold = outlier_threshold(problem.active.size, rows, options.outlier_alpha)
    flagged = np.flatnonzero(stat > threshold)
    exclude = options.robust is not RobustLoss.NONE and options.exclude_outliers
    raw = ev.residuals / problem.weights
    errors = PoseErrors.from_raw(raw)
    found = tuple(
        Outlier(
            pose=int(problem.active[k]),
            position_mm=float(errors.position_mm[k]),
            orientation_deg=None if errors.orientation_rad is None else float(np.degrees(errors.orientation_rad[k])),
            statistic=float(stat[k]),
            threshold=threshold,
            excluded=exclude,
        )
        for k in flagged
    )
    return found, (problem.active[flagged] if exclude else np.empty(0, dtype=np.intp))


def _pose_errors(desc: RobotDescription, campaign: Campaign, theta: Array, seeds: Array | None) -> PoseErrors:
    platforms, _ = solve_platforms(desc, campaign.joints, theta, seeds)
    rot = np.broadcast_to(np.eye(3), (campaign.size, 3, 3)).copy() if campaign.position_only else campaign.rotations
    (res,) = functions_for(desc).batch("residual_at", campaign.joints, theta, platforms, campaign.positions, rot)
    return PoseErrors.from_raw(res[:, :3] if campaign.position_only else res)


@lru_cache(maxsize=16)
def _workspace(desc: RobotDescription, n: int) -> Array:
    return sample_workspace(desc, n, seed=WORKSPACE_SEED + 1)


def predicted_accuracy(
    desc: RobotDescription, theta: Array, free: Array, cov_theta: Array, samples: int
) -> PredictedAccuracy:
    """TCP uncertainty over random workspace poses from the parameter covariance (first order)."""
    joints = _workspace(desc, samples)
    platforms, closure = solve_platforms(desc, joints, theta)
    ok = closure <= CLOSURE_TOLERANCE_MM
    fk = pose_batch(desc, joints[ok], theta, platforms[ok], jacobian=True)
    assert fk.jacobians is not None
    pos, rot = tcp_accuracy(fk.jacobians[:, :, free], cov_theta)
    return PredictedAccuracy(
        rms_position_mm=float(np.sqrt(np.mean(pos**2))),
        max_position_mm=float(pos.max()),
        rms_orientation_deg=float(np.degrees(np.sqrt(np.mean(rot**2)))),
        max_orientation_deg=float(np.degrees(rot.max())),
        poses=int(ok.sum()),
    )


def _failed_geometry(
    desc: RobotDescription,
    *,
    campaign: Campaign,
    theta_nom: Array,
    theta_start: Array,
    solver: SolverReport,
    started: float,
) -> IdentificationResult:
    """The solver ended where some hexapod does not close: report failure, with the starting residuals."""
    table = desc.parameters
    before = ResidualSummary.of(_pose_errors(desc, campaign, theta_start, None))
    nan = float("nan")
    return IdentificationResult(
        status="failed",
        reason=(
            "the solver ended where the model is undefined (some measured hexapod poses do not assemble): these "
            "measurements cannot come from this robot (check the joint order and units, and the robot)"
        ),
        table=table,
        parameters=theta_nom,
        nominal=theta_nom,
        start=theta_start,
        estimated=(),
        std_errors=np.full(len(table), np.nan),
        covariance=np.empty((0, 0)),
        correlated_pairs=(),
        confounding=(),
        rank=0,
        condition_number=nan,
        identifiability_rechecked=False,
        residuals_before=before,
        residuals_after=before,
        variance_factor=nan,
        dof=0,
        noise_consistent=False,
        outliers=(),
        solver=solver,
        predicted_accuracy=PredictedAccuracy(nan, nan, nan, nan, 0),
        position_only=campaign.position_only,
        measurements=campaign.size,
        seconds=time.perf_counter() - started,
    )


__all__ = ["SolveReport", "identify", "minimum_poses", "predicted_accuracy", "structural_identifiability"]
