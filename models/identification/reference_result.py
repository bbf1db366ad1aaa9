"""A campaign against references (ballbar anchors, fixed points, planes, with tracker positions or without) as
the one result every identification gives (`IdentificationResult`), so that the acceptance checks, the report,
the versions and the jobs treat it as they treat a tracker campaign.

What differs is said in the result itself: `references` (each anchor's, point's and plane's unknowns with their
standard errors), `frame` (what the parameters are expressed in when no record fixes one) and `record_kinds`.
A record's error is its own kind's: a distance's and a plane touch's |r|, a point's or a tracker position's
‖r‖, all in mm; an outlier is named by its place in the campaign as given.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.identifiability import structural_identifiability
from models.identification.accuracy import predicted_accuracy, with_record_scatter
from models.identification.options import IdentificationOptions
from models.identification.reference_diagnosis import reference_misfits
from models.identification.reference_fit import (
    FRAME_GROUPS,
    ReferenceFit,
    ReferenceOutlier,
    identify_references,
    record_errors,
)
from models.identification.result import (
    IdentificationResult,
    Outlier,
    PredictedAccuracy,
    ResidualSummary,
    Status,
)
from models.identification.solver import solver_report
from models.identification.statistics import correlated_pairs
from models.measurement import MeasurementKind
from models.measurements.references import ReferenceRecords
from models.noise import NoiseModel


def identify_reference_campaign(
    desc: RobotDescription,
    groups: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    options: IdentificationOptions | None = None,
    runtime: Runtime | None = None,
) -> IdentificationResult:
    """`identify_references`, reported as an `IdentificationResult` (internal units)."""
    started = time.perf_counter()
    rt, noise, options = runtime_for(desc, runtime), noise or NoiseModel(), options or IdentificationOptions()
    fit = identify_references(desc, groups, noise=noise, nominal=nominal, options=options, runtime=rt)
    result = as_result(desc, fit, nominal=nominal, options=options, runtime=rt, started=started)
    found = reference_misfits(desc, fit, noise.position_mm, runtime=rt)
    return replace(result, diagnoses=found, notes=(*result.notes, *(d.message for d in found))) if found else result


def as_result(
    desc: RobotDescription,
    fit: ReferenceFit,
    *,
    nominal: Array | None,
    options: IdentificationOptions,
    runtime: Runtime,
    started: float,
) -> IdentificationResult:
    """The reference fit in the result's terms (see the module docstring)."""
    table = desc.parameters
    names = tuple(table.names[i] for i in fit.estimated)
    before, after = _record_errors(desc, fit, runtime, fitted=False), _record_errors(desc, fit, runtime, fitted=True)
    cov = fit.covariance
    run = fit.solver
    return IdentificationResult(
        status=Status.SUCCEEDED if run.success else Status.FAILED,
        reason=None if run.success else f"IPOPT did not converge: {run.status}",
        table=table,
        parameters=fit.parameters,
        nominal=table.nominal if nominal is None else table.vector(nominal),
        start=fit.start,
        estimated=fit.estimated,
        std_errors=fit.std_errors,
        covariance=fit.parameter_covariance,
        correlated_pairs=correlated_pairs(fit.parameter_covariance, names) if names else (),
        confounding=(),
        rank=len(fit.estimated),
        condition_number=_condition_number(cov.z),
        identifiability_rechecked=fit.rechecked,
        residuals_before=ResidualSummary.of_positions(before),
        residuals_after=ResidualSummary.of_positions(after),
        variance_factor=cov.variance_factor,
        dof=cov.dof,
        noise_consistent=cov.noise_consistent,
        variance_interval=cov.chi2_interval,
        outliers=tuple(_outlier(fit, o, after) for o in fit.outliers),
        solver=solver_report([fit.solver], evaluations=fit.evaluations, polish_steps=fit.polish_steps),
        predicted_accuracy=_accuracy(desc, fit, after, options, runtime),
        kind=MeasurementKind.POSITION,
        measurements=int(np.unique(np.concatenate([g.positions for g in fit.groups])).size),
        seconds=time.perf_counter() - started,
        notes=_notes(fit),
        references=fit.references,
        frame=fit.frame,
        record_kinds=_kinds(fit.groups),
    )


def _accuracy(
    desc: RobotDescription, fit: ReferenceFit, after: Array, options: IdentificationOptions, runtime: Runtime
) -> PredictedAccuracy:
    """The predicted TCP accuracy over the workspace and at the campaign's poses; where every record is a position
    in mm (tracker, reflector, point), also a fresh record's predicted error there."""
    free = np.array(fit.estimated)
    accuracy = predicted_accuracy(
        desc,
        fit.parameters,
        free,
        fit.parameter_covariance,
        options.workspace_samples,
        runtime=runtime,
        measured=_measured_poses(fit),
    )
    if not all(g.reference.traits.position_error for g in fit.groups):
        return accuracy
    return with_record_scatter(accuracy, after, fit.covariance.dof, fit.covariance.z.shape[0])


def _measured_poses(fit: ReferenceFit) -> Array:
    """The campaign's poses once each (a pose read at three reflectors is one pose): the region the prediction is
    also given at, as a tracker campaign's is. Without it a reference or reflector campaign reported only the
    workspace-wide figure, with no word on where it was measured (TIAGo's 37 postures read at four markers)."""
    return np.unique(np.vstack([g.joints for g in fit.groups]), axis=0)


def _notes(fit: ReferenceFit) -> tuple[str, ...]:
    notes = [fit.frame] if fit.unidentifiable else []
    if not fit.rechecked:
        notes.append(
            "at the solution these records no longer determine every parameter chosen at the start (the "
            "linearisation did not hold): measure more varied poses"
        )
    return tuple(notes)


def _record_errors(desc: RobotDescription, fit: ReferenceFit, rt: Runtime, *, fitted: bool) -> Array:
    """Each record's error in the campaign's order, at the start (the start parameters and the references'
    closed-form starts) or at the solution."""
    if fitted:
        return record_errors(desc, fit.groups, fit.parameters, tuple(e.values for e in fit.references), rt)
    starts = tuple(np.array([s.nominal for s in g.reference.unknowns]) for g in fit.groups)
    return record_errors(desc, fit.groups, fit.start, starts, rt)


def _outlier(fit: ReferenceFit, outlier: ReferenceOutlier, errors: Array) -> Outlier:
    """A flagged record, named by its place in the campaign as given (`errors` in that order)."""
    pose = int(fit.groups[outlier.group].positions[outlier.record])
    k = int(np.searchsorted(np.sort(np.concatenate([g.positions for g in fit.groups])), pose))
    return Outlier(pose, float(errors[k]), None, outlier.statistic, outlier.threshold, outlier.excluded)


def _condition_number(cov_z: Array) -> float:
    """cond(J) of the scaled Jacobian, from its covariance s²(JᵀJ)⁻¹: √(λmax / λmin)."""
    if cov_z.size == 0:
        return float("nan")
    eig = np.linalg.eigvalsh(cov_z)
    return math.sqrt(float(eig[-1] / eig[0])) if eig[0] > 0 else float("inf")


def _kinds(groups: tuple[ReferenceRecords, ...]) -> tuple[tuple[str, int], ...]:
    counts: dict[str, int] = {}
    for g in groups:
        kind = g.reference.traits.record_kind
        counts[kind] = counts.get(kind, 0) + int(np.unique(g.positions).size)  # an image's points: one record
    return tuple(counts.items())


def expected_rank(desc: RobotDescription, candidates: tuple[int, ...], *, fixes_frame: bool, runtime: Runtime) -> int:
    """How many of `candidates` a generic campaign of these kinds identifies: as many as tracker positions do
    where a record fixes the frame; else what the candidates and the base identify together less what the base
    does alone (moving the robot and every reference rigidly changes no record): the count the acceptance check
    holds a reference campaign to."""
    if fixes_frame:
        return structural_identifiability(desc, candidates, MeasurementKind.POSITION, runtime=runtime).rank
    base = tuple(desc.parameters.indices(FRAME_GROUPS))
    together = tuple(sorted({*candidates, *base}))
    rank = structural_identifiability(desc, together, MeasurementKind.POSITION, runtime=runtime).rank
    return rank - structural_identifiability(desc, base, MeasurementKind.POSITION, runtime=runtime).rank
