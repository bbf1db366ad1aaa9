"""Measured poses → the robot's real parameters.

Steps: validate and register the instrument frame in closed form; find the
identifiable subset from the weighted, column-scaled Jacobian (the same
analysis pose design uses, `models.identifiability`); solve the weighted
least-squares problem with IPOPT (optionally robust, then without the flagged
outliers) and polish it; report the a-posteriori statistics, re-check
identifiability at the solution, and predict the TCP accuracy the result gives
over the workspace.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.description.parameters import ParameterTable
from models.description.robot import RobotDescription
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime, runtime_for
from models.errors import (
    CalibrationError,
    InconsistentData,
    InvalidInput,
    NonFiniteValue,
    NotIdentifiable,
    SolverFailed,
    TooFewMeasurements,
    UnreachablePose,
)
from models.identifiability import (
    REGAINED_RTOL,
    Identifiability,
    analyse_identifiability,
    condition_support,
    minimum_poses,
    numerical_rank,
    scaled_jacobian,
    structural_identifiability_at,
    structural_support,
    without_unsupported,
)
from models.identification.accuracy import pose_errors, predicted_accuracy, with_record_scatter
from models.identification.bounds import solver_bounds
from models.identification.diagnosis import Diagnosis, Finding, diagnose
from models.identification.options import IdentificationOptions, RobustLoss
from models.identification.outliers import find_outliers
from models.identification.polish import polish
from models.identification.registration import registered_base, rigid_fit
from models.identification.residuals import CampaignProblem, Evaluation, Loss
from models.identification.result import (
    IdentificationResult,
    Outlier,
    PredictedAccuracy,
    ResidualSummary,
    SolverReport,
    Status,
)
from models.identification.solver import FINISHED_BY, SolverPool, SolverRun, solver_pool, solver_report
from models.identification.statistics import Covariance, PoseErrors, correlated_pairs, covariance, outlier_threshold
from models.identification.terms_check import missing_term_diagnoses
from models.identification.trust_region import (
    UNOBSERVABLE_SIGMA,
    describe_unobservable,
    on_observable_directions,
    trust_region_finish,
)
from models.kinematics import forward_kinematics
from models.noise import NoiseModel
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

INCONSISTENT_SIGMA = 100.0
MAX_EXCLUDED_SHARE = 0.2
"""Outlier exclusion removes at most this share of a campaign's poses (blunders are few; more is a misfit)."""
"""A fit whose RMS standardised residual exceeds this cannot come from this robot with the stated noise."""
UNDEFINED_MODEL = (
    "the solver ended where the model is undefined (some measured hexapod poses do not assemble): these "
    "measurements cannot come from this robot (check the joint order and units, and the robot)"
)


@single_threaded_blas
def identify(
    desc: RobotDescription,
    campaign: Campaign,
    *,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    options: IdentificationOptions | None = None,
    runtime: Runtime | None = None,
    strict: bool = False,
) -> IdentificationResult:
    """Identify the parameters of `desc` from `campaign` (internal units throughout).

    A fit that fails comes back with `status` FAILED and its reason; with `strict=True` it raises instead:
    `SolverFailed` when IPOPT did not converge, `InconsistentData` when the data cannot come from this robot.
    """
    # Long on purpose: the pipeline's steps in order (validate, scale, solve, statistics, diagnoses), each a
    # call, kept in one place so the order, which the result's meaning depends on, reads top to bottom.
    started = time.perf_counter()
    rt = runtime_for(desc, runtime)
    noise, options = _checked(noise or NoiseModel()), options or IdentificationOptions()
    table = desc.parameters
    if options.prior is not None:
        options.prior.check(table)  # PriorMismatch: a prior of another robot model
    theta_nom = table.nominal if nominal is None else table.vector(nominal)
    if not np.all(np.isfinite(theta_nom)):
        raise NonFiniteValue("the nominal parameters contain non-finite numbers")
    # A term switched on is estimated (that is what switching it on asks for), whatever groups are listed.
    candidates = tuple(sorted(set(table.indices(options.estimate)) | set(desc.term_index.values())))
    campaign.condition_inputs(desc)  # InvalidInput now when the terms need what the records lack
    check_enough(desc, campaign, candidates, runtime=rt)
    notes: list[str] = []

    # 0. the slips a user makes (radians, metres, a mirrored frame, a quaternion order): named before any fit
    found = diagnose(desc, campaign.joints, campaign.positions, campaign.quaternions, theta_nom, runtime=rt)
    blocking = [d for d in found if d.blocking]
    if blocking:
        return _not_fitted(desc, campaign, theta_nom, found, blocking, started=started, rt=rt, strict=strict)
    notes += [d.message for d in found]
    theta_nom_used = _with_measured_tool_rotation(desc, theta_nom, found, candidates)
    # Records far off all the others (a wrong row, another point's name) would drag least squares to where the
    # hexapod does not assemble before any outlier test could see them: left out from the start, and reported.
    far = [r for d in found if d.finding is Finding.FAR_RECORDS for r in d.records]
    drop_far = bool(far) and options.robust is not RobustLoss.NONE and options.exclude_outliers
    active = np.setdiff1d(np.arange(campaign.size), far) if drop_far else None

    # 1. the instrument frame, in closed form
    theta_start, seeds = _registered_start(
        desc, campaign, theta_nom=theta_nom_used, candidates=candidates, notes=notes, rt=rt, active=active
    )
    # 2. what these data can identify, at the start
    start = forward_kinematics(
        desc, campaign.joints, theta_start, jacobian=True, seeds=seeds, runtime=rt, conditions=campaign.conditions
    )
    scaled = scaled_jacobian(start.jacobians, table, noise, kind=campaign.kind)
    ident = _identifiable(
        desc, _with_prior(scaled, table, options), candidates=candidates, campaign=campaign, notes=notes, rt=rt
    )
    if options.prior is not None:
        # With a prior's rows every direction it covers is "determined", also those no data sees: the rank is
        # what is estimated, the structure's subset, not the stacked matrix's.
        ident = replace(ident, rank=len(ident.identifiable))
    # 3. the weighted least squares: robust first if asked, then without the outliers; polished
    free = np.array(ident.identifiable)
    # AUTO starts plain: the robust loss joins only if the χ² test finds gross errors (see _solve).
    loss = Loss(RobustLoss.NONE if options.robust is RobustLoss.AUTO else options.robust, options.robust_scale)
    problem = CampaignProblem(
        desc,
        rt,
        campaign,
        noise,
        theta_start,
        free,
        loss,
        active=active,
        platforms=start.platforms.copy(),
        prior=options.prior,
    )
    problem, final, solver, outliers, ident = _regained(
        _solve(problem, options, notes), ident=ident, candidates=candidates, options=options, notes=notes
    )
    if drop_far and final is not None:
        outliers = _far_outliers(problem, far, final.theta, options) + outliers
    # 4. what the fit says about itself (nothing, where the model is undefined at the solution)
    estimate = (
        None
        if final is None
        else _estimate(problem, final, ident=ident, candidates=candidates, options=options, notes=notes)
    )
    if estimate is not None and final is not None and not estimate.cov.noise_consistent:
        # A geometric model that misfits data measured at several temperatures (loads): say which term may
        # be missing, from the residuals themselves.
        found = found + missing_term_diagnoses(problem, final)
        notes += [d.message for d in found if d.finding in (Finding.TEMPERATURE_TERM, Finding.LOAD_TERM)]
    reason: str | None
    if estimate is None or final is None:
        before = pose_errors(desc, campaign, theta_start, None, runtime=rt)
        status, reason, notes = Status.FAILED, UNDEFINED_MODEL, []
    else:
        before = pose_errors(desc, campaign, theta_start, start.platforms, runtime=rt)
        unobservable, hold = describe_unobservable(final.jacobian, tuple(table.names[i] for i in problem.free))
        status, reason = _verdict(solver, estimate.cov, notes, unobservable=unobservable, hold=hold)
    result = make_result(
        table,
        campaign,
        status=status,
        reason=reason,
        nominal=theta_nom,
        start=theta_start,
        solver=solver,
        before=ResidualSummary.of(before),
        estimate=estimate,
        outliers=outliers,
        notes=notes,
        started=started,
        diagnoses=found,
    )
    if strict and not result.succeeded:
        _raise(result, estimate)
    return result


@dataclass(frozen=True)
class Estimate:
    """What a fit that ended where the model is defined says about itself."""

    theta: Array
    free: Array
    cov: Covariance
    cov_theta: Array
    """A-posteriori covariance of the estimated parameters, internal units."""
    ident: Identifiability
    rechecked: bool
    after: ResidualSummary
    accuracy: PredictedAccuracy
    prediction_cov: Array
    """The predictive covariance of `_by_direction` (the prior's covariance where a prior bounds every direction)."""


def _checked(noise: NoiseModel) -> NoiseModel:
    values = [noise.position_mm, noise.orientation_rad]
    if not (noise.position_mm > 0 and noise.orientation_rad > 0 and np.isfinite(values).all()):
        raise InvalidInput(
            "the instrument noise must be positive and finite (σ position in mm, σ orientation)", field="noise"
        )
    return noise


def check_enough(
    desc: RobotDescription, campaign: Campaign, candidates: tuple[int, ...], *, runtime: Runtime | None = None
) -> None:
    """TooFewMeasurements unless the campaign has the poses the structure needs for these parameters."""
    rank, needed = minimum_poses(desc, candidates, campaign.kind, runtime=runtime)
    if campaign.size < needed:
        raise TooFewMeasurements(
            f"{campaign.size} {campaign.kind.label} measurements cannot determine the {rank} identifiable "
            f"parameters: at least {needed} are needed, so measure {needed - campaign.size} more (for a useful "
            "accuracy, 3-5 times that)",
            got=campaign.size,
            needed=needed,
            missing=needed - campaign.size,
            kind=campaign.kind.value,
        )


def _registered_start(
    desc: RobotDescription,
    campaign: Campaign,
    *,
    theta_nom: Array,
    candidates: tuple[int, ...],
    notes: list[str],
    rt: Runtime,
    active: Array | None,
) -> tuple[Array, Array]:
    """The nominal parameters with the instrument frame as base (when estimated, fitted on the `active` poses),
    and the platform poses."""
    fk = forward_kinematics(desc, campaign.joints, theta_nom, runtime=rt, conditions=campaign.conditions)
    if set(desc.parameters.groups["base"]) <= set(candidates):
        used = slice(None) if active is None else active
        fit = rigid_fit(fk.positions[used], campaign.positions[used])
        return registered_base(desc, theta_nom, fit), fk.platforms
    notes.append("the base (instrument frame) is not estimated: the given base is taken as exact")
    return theta_nom, fk.platforms


def _with_measured_tool_rotation(
    desc: RobotDescription, theta: Array, found: tuple[Diagnosis, ...], candidates: tuple[int, ...]
) -> Array:
    """`theta` with the tool's rotation the records show (a TOOL_ORIENTATION finding), where the fit estimates
    the tool's rotation: started 90° or 180° off, the fit would end in another minimum or stop."""
    tool = desc.slices["tool"]
    rotation = list(range(tool.start + 3, tool.stop))
    measured = next((d.tool_rotation for d in found if d.tool_rotation is not None), None)
    if measured is None or not set(rotation) <= set(candidates):
        return theta
    out = theta.copy()
    out[rotation] = matrix_to_rotvec_np(rotvec_to_matrix_np(theta[rotation]) @ measured)
    return out


def _with_prior(scaled: Array, table: ParameterTable, options: IdentificationOptions) -> Array:
    """The data's scaled rows, with a prior's rows beneath: what data and prior together determine."""
    if options.prior is None:
        return scaled
    return np.vstack([scaled, options.prior.information_rows(table)])


def _identifiable(
    desc: RobotDescription,
    scaled: Array,
    *,
    candidates: tuple[int, ...],
    campaign: Campaign,
    notes: list[str],
    rt: Runtime,
) -> Identifiability:
    """The structural subset if these data determine it; otherwise the data's own (smaller) subset."""
    support = structural_support(desc, scaled, candidates, campaign.kind, runtime=rt)
    full = analyse_identifiability(scaled, desc.parameters, candidates)
    structural = support.structural
    # The structure's subset even where these poses do not determine all of it: dropping the columns a
    # pivoted QR finds weakest in one campaign drops what it does see (measured: 40 records on a straight line
    # kept 22 of 26 and lost the tool's offset, 2.7x the held-out error of a fit of every parameter). The
    # directions the campaign cannot see are left where they start by the solver and named after the fit.
    full = replace(
        full,
        identifiable=structural.identifiable,
        unidentifiable=structural.unidentifiable,
        confounding=structural.confounding,
    )
    if not support.supported:
        notes.append(
            f"these poses determine only {support.data_rank} of the {support.structural.rank} parameters rich "
            "data would: the directions they cannot see stay at their start values, and predictions along them "
            "are extrapolation (measure more varied poses)"
        )
    unsupported = {i: m for i, m in condition_support(desc, campaign.conditions).items() if i in candidates}
    full = without_unsupported(full, unsupported)
    notes += list(unsupported.values())
    if not full.identifiable:
        raise NotIdentifiable("the measurements determine none of the requested parameters")
    return full


def _solve(
    problem: CampaignProblem, options: IdentificationOptions, notes: list[str]
) -> tuple[CampaignProblem, Evaluation | None, SolverReport, tuple[Outlier, ...]]:
    """IPOPT (with the robust loss if asked; AUTO: plain, and robust only when the χ² test flags a pose); again
    without the excluded outliers; then Gauss–Newton polish.

    Returns the problem of the last solve and its evaluation at the polished solution (None where the model
    is undefined there).
    """
    # Long on purpose: the solve-reweigh-polish loop shares its evaluation counts and warm starts across rounds.
    pool = solver_pool(problem.runtime)
    lower, upper = solver_bounds(problem, options)
    z0 = np.clip(np.zeros(problem.n_free), lower, upper)
    runs = [_run(pool, problem, z0, lower, upper, max_iter=options.max_iterations)]
    evaluations = 0  # of the problems already left behind
    first = problem.evaluate(runs[0].z)
    robust = options.robust
    exclude = options.exclude_outliers and robust is not RobustLoss.NONE
    outliers, excluded = find_outliers(problem, runs[0].z, options, exclude=exclude and robust is not RobustLoss.AUTO)
    if robust is RobustLoss.AUTO and first is not None and outliers:
        # Least squares smears a blunder over many poses (measured: one 2.5 mm blunder flags 27 of 40); a
        # soft-ℓ1 refit from there isolates it, and the χ² test on the robust residuals names the real ones.
        # When the robust fit finds more than a few (or does not converge), the data misfit the model as a
        # whole: the plain fit stands, its flags reported, nothing excluded.
        plain, plain_run = problem, runs[0]
        robust_problem = replace(
            problem, loss=Loss(RobustLoss.SOFT_L1, options.robust_scale), _last=None, evaluations=0
        )
        robust_run = _run(pool, robust_problem, runs[0].z, lower, upper, max_iter=options.max_iterations)
        found, dropped = find_outliers(robust_problem, robust_run.z, options, exclude=exclude)
        if robust_run.success and dropped.size <= MAX_EXCLUDED_SHARE * problem.campaign.size:
            evaluations += problem.evaluations
            problem, outliers, excluded = robust_problem, found, dropped
            runs.append(robust_run)
        else:
            evaluations += robust_problem.evaluations
            problem, runs = plain, [plain_run]
            notes.append(
                f"{len(outliers)} of {problem.campaign.size} poses fail the outlier test even after a robust "
                "refit: more than a few blunders, so none was excluded (the model, its start values or the stated "
                "noise do not fit these data)"
            )
    if excluded.size > MAX_EXCLUDED_SHARE * problem.campaign.size:
        # Blunders are a few poses; when the test flags this many, the model or the stated noise misfits the
        # campaign as a whole (a base-only fit of an uncalibrated robot, shuffled records): dropping them would
        # hide that, and could leave nothing to fit.
        notes.append(
            f"{excluded.size} of {problem.campaign.size} poses fail the outlier test: more than a few blunders, "
            "so none was excluded (the model, its start values or the stated noise do not fit these data)"
        )
        outliers = tuple(replace(o, excluded=False) for o in outliers)
        excluded = excluded[:0]
    if first is not None and excluded.size:
        evaluations += problem.evaluations
        keep = np.setdiff1d(problem.active_poses, excluded)
        problem = replace(problem, loss=Loss(), active=keep, _last=None, evaluations=0)
        runs.append(_run(pool, problem, runs[-1].z, lower, upper, max_iter=options.max_iterations))
    if runs[-1].status.startswith(FINISHED_BY):
        # The finish already tested the decrement on the observable directions; the polish's normal equations
        # would square a condition number of ~1e9 and step along directions the campaign cannot see.
        polished, polish_steps = runs[-1].z, 0
    else:
        polished, polish_steps = polish(problem, runs[-1].z, lower, upper)
    final = problem.evaluate(polished)
    solver = solver_report(runs, evaluations=evaluations + problem.evaluations, polish_steps=polish_steps)
    return problem, final, solver, outliers


def _run(
    pool: SolverPool, problem: CampaignProblem, z0: Array, lower: Array, upper: Array, *, max_iter: int
) -> SolverRun:
    """IPOPT; where it stops short (its iteration limit, a stalled line search), a trust-region least-squares
    finish from its end point (`trust_region.py`: at a Jacobian condition of ~1e9 the Gauss–Newton Hessian IPOPT
    solves with is at ~1e18, past double precision; factoring the Jacobian itself is not). The run reports
    both: the status names IPOPT's end and the finish's."""
    run = pool.solve(problem, z0, lower, upper, max_iter)
    if run.success:
        # IPOPT too drifts along the directions the records do not see (a small region's campaign): put back.
        z = on_observable_directions(problem, run.z)
        return run if z is run.z else replace(run, z=z, objective=_objective(problem, z, run.objective))
    finish = trust_region_finish(problem, run.z, lower, upper)
    return SolverRun(
        z=finish.z if finish.success else run.z,
        status=f"{FINISHED_BY}{finish.status} (IPOPT: {run.status})",
        success=finish.success,
        iterations=run.iterations + finish.iterations,
        seconds=run.seconds + finish.seconds,
        objective=finish.objective if finish.success else run.objective,
    )


def _objective(problem: CampaignProblem, z: Array, otherwise: float) -> float:
    ev = problem.evaluate(z)
    return otherwise if ev is None else ev.objective


def _regained(
    fit: tuple[CampaignProblem, Evaluation | None, SolverReport, tuple[Outlier, ...]],
    *,
    ident: Identifiability,
    candidates: tuple[int, ...],
    options: IdentificationOptions,
    notes: list[str],
) -> tuple[CampaignProblem, Evaluation | None, SolverReport, tuple[Outlier, ...], Identifiability]:
    """The structure's subset chosen again at the fitted geometry, and the fit repeated from the solution with
    it, when that geometry makes more parameters identifiable than the nominal one did.

    Measured (ROS-Industrial's IRB 2400 URDF, `tool0` on joint 6's axis, the reflector 50 mm off it, 40 position
    records, σ 30 µm): 25 parameters at the nominal geometry, 27 at the fitted one; the 25-parameter fit leaves
    joint 6's offset and twist at nominal and 2-3× the held-out error of the 27-parameter one."""
    problem, final, solver, outliers = fit
    if final is None or options.prior is not None:  # with a prior, data and prior decide (see _identifiable)
        return problem, final, solver, outliers, ident
    desc = problem.desc
    if desc.term_index:
        # The terms' parameters are identifiable by the conditions the records span, which the structural
        # analysis at rich conditions does not see (`_identifiable`'s `without_unsupported`).
        return problem, final, solver, outliers, ident
    try:
        again = structural_identifiability_at(
            desc, final.theta, candidates, problem.campaign.kind, runtime=problem.runtime
        )
    except CalibrationError:  # a workspace sample the fitted hexapod does not assemble: keep the nominal subset
        return problem, final, solver, outliers, ident
    gained = sorted(set(again.identifiable) - set(ident.identifiable))
    if again.rank <= ident.rank or not gained:
        return problem, final, solver, outliers, ident
    if not _records_see(problem, final.theta, again):
        return problem, final, solver, outliers, ident
    notes.append(
        f"at the fitted geometry {again.rank} parameters are identifiable (at the nominal one: {ident.rank}, which "
        "is special: a tool on the last joint's axis, exactly parallel or intersecting axes): fitted again with the "
        f"subset chosen there ({', '.join(desc.parameters.names[i] for i in gained)} joined)"
    )
    regained = replace(
        ident,
        identifiable=again.identifiable,
        unidentifiable=again.unidentifiable,
        confounding=again.confounding,
        rank=ident.rank + again.rank - len(ident.identifiable),
    )
    start = final.theta
    refit = replace(problem, theta_start=start, free=np.array(again.identifiable), _last=None, evaluations=0)
    refit.__post_init__()
    problem2, final2, solver2, outliers2 = _solve(refit, options, notes)
    if final2 is None:
        return problem, final, solver, outliers, ident
    total = replace(
        solver2,
        iterations=solver.iterations + solver2.iterations,
        seconds=solver.seconds + solver2.seconds,
        evaluations=solver.evaluations + solver2.evaluations,
        success=solver.success and solver2.success,
    )
    return problem2, final2, total, outliers2, regained


def _records_see(problem: CampaignProblem, theta: Array, again: Identifiability) -> bool:
    """Whether the campaign's own records (without those left out as outliers) have the rank of the subset chosen
    at `theta`: a campaign of a small region (a line) leaves its unobservable directions wherever the solver did,
    and a geometry fitted there is no better guide."""
    campaign = problem.campaign.subset(problem.active_poses)
    try:
        seen = forward_kinematics(
            problem.desc,
            campaign.joints,
            theta,
            jacobian=True,
            check_ranges=False,
            runtime=problem.runtime,
            conditions=campaign.conditions,
        )
    except CalibrationError:  # a record the fitted model cannot place (a blunder's hexapod pose): no regain
        return False
    scaled = scaled_jacobian(seen.jacobians, problem.desc.parameters, problem.noise, kind=campaign.kind)
    return numerical_rank(scaled, again.identifiable, rtol=REGAINED_RTOL) >= again.rank


def _far_outliers(
    problem: CampaignProblem, far: list[int], theta: Array, options: IdentificationOptions
) -> tuple[Outlier, ...]:
    """The records left out before the fit, with their residual at the solution `theta`, worst first."""
    campaign = problem.campaign
    subset = replace(campaign.subset(far), sigma_mm=None)
    try:
        errors = pose_errors(problem.desc, subset, theta, None, runtime=problem.runtime)
    except CalibrationError:  # a record so wrong the model cannot even evaluate it
        nan = np.full(len(far), np.nan)
        errors = PoseErrors(nan, None if campaign.position_only else nan)
    weights = problem.weights[far]  # 1/σ per record (its own σ where the campaign gives one)
    statistic = (errors.position_mm * weights[:, 0]) ** 2
    if errors.orientation_rad is not None:
        statistic = statistic + (errors.orientation_rad * weights[:, 3]) ** 2
    threshold = outlier_threshold(campaign.size, problem.rows, options.outlier_alpha)
    order = np.argsort(-np.nan_to_num(statistic, nan=np.inf), kind="stable")
    return tuple(
        Outlier.at(errors, k, pose=int(far[k]), statistic=statistic[k], threshold=threshold, excluded=True)
        for k in order
    )


def _estimate(
    problem: CampaignProblem,
    ev: Evaluation,
    *,
    ident: Identifiability,
    candidates: tuple[int, ...],
    options: IdentificationOptions,
    notes: list[str],
) -> Estimate | None:
    """Covariance, residuals, re-checked identifiability and predicted accuracy at the solution `ev` (None
    where the final forward kinematics finds the model undefined)."""
    rt = problem.runtime
    desc, campaign, table, free = problem.desc, problem.campaign, problem.desc.parameters, problem.free
    prior_rows = None if problem.prior_rows is None else problem.prior_rows.jacobian
    cov = covariance(ev.jacobian, ev.residuals, prior_rows)
    scales = table.scales[free]
    cov_theta = cov.z * np.outer(scales, scales)
    after = pose_errors(desc, campaign, ev.theta, problem.platforms, runtime=rt)
    try:
        final = forward_kinematics(
            desc,
            campaign.joints,
            ev.theta,
            jacobian=True,
            seeds=problem.platforms,
            check_ranges=False,
            runtime=rt,
            conditions=campaign.conditions,
        )
    except UnreachablePose:
        return None
    scaled = _with_prior(scaled_jacobian(final.jacobians, table, problem.noise, kind=campaign.kind), table, options)
    # The terms' parameters these conditions cannot determine stay out of the recheck, as out of the fit.
    missing = {name for name, _ in ident.missing}
    # With a prior, the question is whether data and prior still determine what was estimated.
    pool = candidates if options.prior is None else ident.identifiable
    recheck = analyse_identifiability(scaled, table, tuple(i for i in pool if table.names[i] not in missing))
    if recheck.rank != ident.rank:
        notes.append(
            f"at the solution {recheck.rank} parameters are identifiable (at the start: {ident.rank}); "
            "the estimate used the starting subset"
        )
    observable, prediction_cov = (None, cov_theta) if prior_rows is not None else _by_direction(ev, cov, scales)
    accuracy = predicted_accuracy(
        desc,
        ev.theta,
        free,
        cov_theta,
        options.workspace_samples,
        runtime=rt,
        measured=campaign.joints,
        observable_cov_theta=observable,
    )
    accuracy = with_record_scatter(accuracy, after.position_mm, cov.dof, free.size)
    if accuracy.extrapolation is not None:
        notes.append(accuracy.extrapolation)
    summary, rechecked = ResidualSummary.of(after), recheck.rank == ident.rank
    return Estimate(ev.theta, free, cov, cov_theta, ident, rechecked, summary, accuracy, prediction_cov)


def _by_direction(ev: Evaluation, cov: Covariance, scales: Array) -> tuple[Array, Array]:
    """(observable, predictive) covariances in internal units, from the Jacobian's SVD (inverting JᵀJ at
    condition 1e17 leaves the observable directions noise, negative variances included).

    Observable: the a-posteriori covariance restricted to the directions the records observe
    (`trust_region.UNOBSERVABLE_SIGMA`), what the measured region's prediction uses. Predictive: that, plus one
    tolerance² along each direction the records did not see, which the fit left at its start: the error there
    is the start's, each parameter's expected error, not the thousands of tolerances of its a-posteriori
    variance; what a prediction at a fresh pose uses (`models.identification.pose_accuracy`)."""
    rows, unknowns = ev.jacobian.shape
    # Every right singular vector, with fewer rows than unknowns too (the rest is the null space, unseen);
    # full U only then, where it is small (6 000 rows would make it 288 MB).
    _, sv, vt = np.linalg.svd(ev.jacobian, full_matrices=rows < unknowns)
    sv = np.concatenate([sv, np.zeros(vt.shape[0] - sv.size)])
    seen = sv > UNOBSERVABLE_SIGMA
    factor = cov.variance_factor if np.isfinite(cov.variance_factor) else 1.0
    observable = factor * (vt[seen].T / sv[seen] ** 2) @ vt[seen]
    to_internal = np.outer(scales, scales)
    unseen = vt[~seen]
    return np.asarray(observable * to_internal), np.asarray((observable + unseen.T @ unseen) * to_internal)


def _verdict(
    solver: SolverReport, cov: Covariance, notes: list[str], *, unobservable: str = "", hold: tuple[str, ...] = ()
) -> tuple[Status, str | None]:
    rms_sigma = math.sqrt(cov.variance_factor) if np.isfinite(cov.variance_factor) else float("nan")
    if not solver.success:
        cause = (
            f" {unobservable}. Hold {', '.join(hold)} (leave them out of `estimate`) or measure poses that move "
            "them (other orientations, a wider region)"
            if unobservable
            else ""
        )
        return Status.FAILED, f"IPOPT did not converge: {solver.status}.{cause}"
    if unobservable:
        notes.append(
            f"{unobservable}: they stay near their start values, and predictions that depend on them are extrapolation"
        )
    if rms_sigma > INCONSISTENT_SIGMA:
        return Status.FAILED, (
            f"after the fit the residuals are still {rms_sigma:.0f} σ (RMS): these measurements cannot come from "
            "this robot with the stated noise (check the joint order and units, the robot, and the noise)"
        )
    if not cov.noise_consistent:
        notes.append(
            f"variance factor {cov.variance_factor:.3g} is outside [{cov.chi2_interval[0]:.3g}, "
            f"{cov.chi2_interval[1]:.3g}]: the stated instrument noise does not match the residuals"
        )
    return Status.SUCCEEDED, None


def make_result(
    table: ParameterTable,
    campaign: Campaign,
    *,
    status: Status,
    reason: str | None,
    nominal: Array,
    start: Array,
    solver: SolverReport,
    before: ResidualSummary,
    estimate: Estimate | None,
    outliers: tuple[Outlier, ...],
    notes: list[str],
    started: float,
    diagnoses: tuple[Diagnosis, ...] = (),
) -> IdentificationResult:
    """The one constructor of a result; without an estimate, the parameters stay nominal and nothing is
    reported as estimated."""
    e = estimate
    nan = float("nan")
    free = () if e is None else tuple(int(i) for i in e.free)
    std = np.full(len(table), np.nan)
    if e is not None:
        std[e.free] = np.sqrt(np.diag(e.cov_theta))
    return IdentificationResult(
        status=status,
        reason=reason,
        table=table,
        parameters=nominal if e is None else e.theta,
        nominal=nominal,
        start=start,
        estimated=free,
        std_errors=std,
        covariance=np.empty((0, 0)) if e is None else e.cov_theta,
        correlated_pairs=() if e is None else correlated_pairs(e.cov_theta, tuple(table.names[i] for i in free)),
        confounding=() if e is None else e.ident.confounding,
        rank=0 if e is None else e.ident.rank,
        condition_number=nan if e is None else e.ident.condition_number,
        identifiability_rechecked=False if e is None else e.rechecked,
        residuals_before=before,
        residuals_after=before if e is None else e.after,
        variance_factor=nan if e is None else e.cov.variance_factor,
        dof=0 if e is None else e.cov.dof,
        noise_consistent=False if e is None else e.cov.noise_consistent,
        variance_interval=(nan, nan) if e is None else e.cov.chi2_interval,
        outliers=() if e is None else outliers,
        solver=solver,
        predicted_accuracy=PredictedAccuracy.undefined() if e is None else e.accuracy,
        kind=campaign.kind,
        measurements=campaign.size,
        seconds=time.perf_counter() - started,
        notes=tuple(notes),
        diagnoses=diagnoses,
        missing=() if e is None else e.ident.missing,
        prediction_covariance=None if e is None else e.prediction_cov,
    )


NOT_RUN = SolverReport(
    name="ipopt", status="not_run", success=False, iterations=0, seconds=0.0, objective=0.0, evaluations=0
)


def _not_fitted(
    desc: RobotDescription,
    campaign: Campaign,
    theta_nom: Array,
    found: tuple[Diagnosis, ...],
    blocking: list[Diagnosis],
    *,
    started: float,
    rt: Runtime,
    strict: bool,
) -> IdentificationResult:
    """A campaign a pre-fit check refuses: a failed result naming the slip, without running the solver."""
    reason = " ".join(d.message for d in blocking)
    if strict:
        raise InconsistentData(reason, rms_sigma=None, limit_sigma=INCONSISTENT_SIGMA)
    try:
        before = ResidualSummary.of(pose_errors(desc, campaign, theta_nom, None, runtime=rt))
    except CalibrationError:  # the slip may leave the model undefined at these joints
        nan = np.full(campaign.size, np.nan)
        before = ResidualSummary.of(PoseErrors(nan, None if campaign.position_only else nan))
    return make_result(
        desc.parameters,
        campaign,
        status=Status.FAILED,
        reason=reason,
        nominal=theta_nom,
        start=theta_nom,
        solver=NOT_RUN,
        before=before,
        estimate=None,
        outliers=(),
        notes=[],
        started=started,
        diagnoses=found,
    )


def _raise(result: IdentificationResult, estimate: Estimate | None) -> None:
    """`strict=True`: a failed result becomes the domain error naming why."""
    reason = result.reason or "the identification failed"
    if estimate is None:  # the model is undefined at the solution: not this robot's data
        raise InconsistentData(reason, rms_sigma=None, limit_sigma=INCONSISTENT_SIGMA)
    if not result.solver.success:
        raise SolverFailed(
            reason, solver=result.solver.name, status=result.solver.status, iterations=result.solver.iterations
        )
    factor = estimate.cov.variance_factor
    rms_sigma = math.sqrt(factor) if np.isfinite(factor) else None
    raise InconsistentData(reason, rms_sigma=rms_sigma, limit_sigma=INCONSISTENT_SIGMA)
