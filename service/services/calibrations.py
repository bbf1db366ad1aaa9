from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from sqlalchemy.orm import Session

from models import Registry, RobotDescription
from models._types import Array
from models.errors import InvalidInput
from models.identification import IdentificationOptions, IdentificationResult
from models.identification.acceptance import Acceptance, acceptance_checks, decide
from service.audit_actions import AuditAction
from service.conversions.calibrations import (
    calibration_public,
    diagnoses_out,
    noise_in,
    options_in,
    report_out,
    stored_document,
)
from service.conversions.drift import conditions_out
from service.conversions.references import described
from service.conversions.robots import description
from service.conversions.terms import padded, requested_model
from service.conversions.terms import start_values as start_values_for
from service.errors import CalibrationFailed, Conflict
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle, check_revision
from service.persistence.repository import new_id
from service.persistence.tables import CalibrationRecord, ParameterVersion, Robot
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic, CalibrationReportPublic
from service.services.fleets import Fleet, calibration_prior, comparison_out, read_fleet
from service.services.hooks import JobHooks
from service.services.pipelines import fitting_for


def calibrate(
    *,
    db: Database,
    registry: Registry,
    robot_id: str,
    body: CalibrationCreate,
    actor: Actor | None = None,
    job: JobHooks | None = None,
    if_match: str | None = None,
) -> CalibrationPublic:
    """Identify, then store the campaign, the calibration and (when it passed its checks and `apply`) the new
    version together, with the job's own `succeeded` when run as one. The result as stored; a
    failed fit is stored, then raised as `CalibrationFailed` (a 422 naming the stored attempt; its job fails).

    `if_match` (the robot's ETag) is checked before any work, where the start version is read: the fit then
    applies only over that version (a 409 otherwise, the calibration stored, not applied)."""
    if job is not None:
        job.progress("reading", 0.0)
    start = _read_start(db, robot_id, body, if_match)
    if job is not None:
        job.progress("identifying", 0.05)
    fit = _fit(registry, start, body)
    if job is not None:
        job.progress("storing", 0.95)
    calibration_id = new_id()
    answer, won_by = _store(db, robot_id, body, start, fit, calibration_id=calibration_id, actor=actor, job=job)
    if not fit.result.succeeded:
        raise CalibrationFailed(
            f"the calibration failed and was not applied: {fit.result.reason} (stored as calibration {calibration_id})",
            calibration_id=calibration_id,
            diagnoses=diagnoses_out(fit.result),
        )
    if won_by is not None and job is None:  # after the commit: the calibration is stored, only not applied
        raise Conflict(
            _lost_race(calibration_id, start.version, won_by),
            calibration_id=calibration_id,
            start_version=start.version,
            current_version=won_by,
        )
    return answer


@dataclass(frozen=True)
class _Start:
    """What the fit starts from, read in one transaction: the model with the requested terms, and the start
    version's number, values, per-parameter statistics (padded to the model's parameters) and the predicted
    accuracy of the calibration that made it."""

    desc: RobotDescription
    version: int
    values: Array
    std_errors: list[float | None]
    identifiable: list[float | None]
    accuracy_mm: float | None
    dof: int | None
    """The degrees of freedom of the calibration that made the start version (None: uncalibrated)."""
    robot_id: str
    fleet: Fleet
    """The robot's fleet (`service.services.fleets`): the prior of `options.prior` fleet, the report's comparison."""
    own_nominal: Array
    """The robot's geometric nominal values (its own base and tool guesses)."""


def _read_start(db: Database, robot_id: str, body: CalibrationCreate, if_match: str | None) -> _Start:
    with db.reader() as s:
        repo = Repository(s)
        check_revision(repo.robot(robot_id), if_match)
        # The terms of `options.terms` (a 422 naming it for a robot without the parts they act on); the start
        # version's values for what it has, the terms' nominal values for what it has not.
        desc = requested_model(description(repo.robot(robot_id)), body.options.terms)
        row = _start_version(repo, robot_id, body.start_version)
        stored = np.asarray(row.values, dtype=float)
        same = stored.size == desc.n_params
        return _Start(
            desc=desc,
            version=row.version,
            values=start_values_for(desc, stored),
            std_errors=padded(list(row.std_errors or []) if same else [], desc.n_params, None),
            identifiable=padded(list(row.identifiable or []) if same else [], desc.n_params, False),
            accuracy_mm=_predicted_accuracy(repo, row),
            dof=_made_by(repo, row).get("degrees_of_freedom"),
            robot_id=robot_id,
            fleet=read_fleet(s, repo.robot(robot_id)),
            own_nominal=desc.geometric.parameters.nominal,
        )


@dataclass(frozen=True)
class _Fit:
    result: IdentificationResult
    decision: Acceptance
    report: CalibrationReportPublic


def _with_fleet_prior(options: IdentificationOptions, body: CalibrationCreate, start: _Start) -> IdentificationOptions:
    """`options` with the fleet's population as prior where the request asks for it (options.prior fleet)."""
    if body.options.prior != "fleet":
        return options
    return replace(options, prior=calibration_prior(start.fleet, start.robot_id, start.desc, body.options.fleet))


def _fit(registry: Registry, start: _Start, body: CalibrationCreate) -> _Fit:
    """The identification, its acceptance checks and the decision, and the report (nothing stored yet): one
    pipeline for a campaign of any kinds (`service.services.pipelines`)."""
    desc = start.desc
    way = fitting_for(body.measurements)
    way.refuse_options(body)  # before any conversion: a campaign's options are refused as a whole
    options = _with_fleet_prior(options_in(body), body, start)
    # The fit starts from the chosen version, so whatever it does not estimate keeps that version's calibrated
    # values (a base-only re-fit after the tracker moved must not send the links and legs back to nominal).
    noise = noise_in(body)
    runtime = registry.runtime(desc)
    candidates = desc.parameters.indices(options.estimate)
    everything = desc.parameters.indices(IdentificationOptions().estimate)
    fitting = way.of(desc, body.measurements, described(body), sigma_mm=body.noise.position_mm, payload=body.payload)
    result, drift = fitting.identify(desc, body, noise=noise, nominal=start.values, options=options, runtime=runtime)
    expected = fitting.rank(desc, candidates, runtime=runtime)
    most = fitting.rank(desc, everything, runtime=runtime)
    partial = expected < most  # parameters held at the start version's (calibrated) values
    checks = acceptance_checks(
        result,
        expected_rank=expected,
        start_accuracy_mm=start.accuracy_mm,
        sigma_mm=body.noise.position_mm,
        held_accuracy_mm=start.accuracy_mm if partial else None,
        start_dof=start.dof,
        sigma_stated=_sigma_stated(body),
    )
    decision = decide(checks, succeeded=result.succeeded, requested=body.apply, force=body.force_apply)
    report = report_out(
        desc,
        result,
        start_values=start.values,
        start_version=start.version,
        checks=checks,
        noise=noise,
        drift=drift,
        conditions=conditions_out(body.measurements, body.payload),
    )
    fleet = comparison_out(start.fleet, start.robot_id, start.own_nominal, result, prior_used=options.prior is not None)
    return _Fit(result, decision, report.model_copy(update={"fleet": fleet}))


def _sigma_stated(body: CalibrationCreate) -> bool:
    """Whether the request states the instrument's σ: its `noise`, or a `sigma_mm` on any record (a tracker
    file's U95 / 2). Otherwise the default σ is a placeholder and σ is what the residuals say."""
    if "noise" in body.model_fields_set:
        return True
    return any(getattr(m, "sigma_mm", None) is not None for m in body.measurements)


def _store(
    db: Database,
    robot_id: str,
    body: CalibrationCreate,
    start: _Start,
    fit: _Fit,
    *,
    calibration_id: str,
    actor: Actor | None,
    job: JobHooks | None,
) -> tuple[CalibrationPublic, int | None]:
    """The campaign, the calibration and, when applied, the new version and its audit event, in one
    transaction; (the calibration as stored, the version that won the race if another became current)."""
    result, decision = fit.result, fit.decision
    won_by: int | None = None
    with db.session() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id, lock=True)  # still there, and one calibration at a time per robot
        if decision.apply and robot.current_version != start.version:
            # Optimistic concurrency: another writer made a version while this fit ran (or the fit started
            # from an older one). Applying would silently discard that version's work; keep this one stored.
            won_by = robot.current_version
            decision = decision.superseded(_lost_race(calibration_id, start.version, won_by))
        stored = repo.add_campaign(robot_id, [r.model_dump() for r in body.measurements])
        document = fit.report.model_copy(
            update={
                "notes": [*body.import_notes, *fit.report.notes],
                "not_applied_reason": decision.reason,
                "forced": decision.forced,
            }
        )
        record = repo.add_calibration(
            calibration_id, robot_id, stored.id, result.status, stored_document(document, result)
        )
        record.start_version = start.version
        record.notes = body.notes
        record.instrument = None if body.instrument is None else body.instrument.model_dump()
        if decision.apply:
            _apply(s, robot, record, start, fit, who=actor or Actor())
        if job is not None and result.succeeded:
            # The job's `succeeded` joins this transaction (a calibration that lost the race is stored, not
            # applied: its job did its work, the reason is in the result); a failed fit ends the job `failed`
            # below, with the same problem the synchronous request answers.
            job.commit(s, calibration_id)
        return calibration_public(record), won_by


def _apply(s: Session, robot: Robot, record: CalibrationRecord, start: _Start, fit: _Fit, *, who: Actor) -> None:
    """The fit's parameters become the robot's new version, with its audit event (inside `_store`'s
    transaction). What this fit estimated carries its new statistics; the rest keeps the start version's."""
    result, calibration_id = fit.result, record.id
    std, ident = list(start.std_errors), list(start.identifiable)
    for i in result.estimated:
        value = float(result.std_errors[i])
        std[i], ident[i] = (value if np.isfinite(value) else None), True
    previous = robot.current_version
    record.parameter_version = Lifecycle(s).add_version(
        robot,
        values=result.parameters.tolist(),
        std_errors=std,
        identifiable=ident,
        provenance="calibration",
        actor=who,
        calibration_id=calibration_id,
        conditions=None if fit.report.conditions is None else fit.report.conditions.model_dump(mode="json"),
    )
    record.applied = True
    Lifecycle(s).changed(
        robot,
        AuditAction.VERSION_CALIBRATED,
        who,
        version=record.parameter_version,
        # `forced` only when it was: an applied calibration that failed a check (force_apply).
        details={"from_version": previous, "calibration_id": calibration_id}
        | ({"forced": True} if fit.decision.forced else {}),
    )


def _lost_race(calibration_id: str, start_version: int, won_by: int) -> str:
    """The conflict's words: the synchronous request's 409 detail, and a job's `not_applied_reason`."""
    return (
        f"conflict: calibration {calibration_id} is stored but not applied: it started from parameter version "
        f"{start_version}, and version {won_by} became current meanwhile; review both, then calibrate "
        f"again from version {won_by} or restore the one you want"
    )


def _made_by(repo: Repository, version: ParameterVersion) -> dict[str, Any]:
    """The document of the calibration that made `version` ({} for one no calibration made)."""
    if version.calibration_id is None:
        return {}
    return dict(repo.calibration(version.calibration_id).result)


def _predicted_accuracy(repo: Repository, version: ParameterVersion) -> float | None:
    """The start version's predicted RMS TCP accuracy, from the calibration that made it (None: uncalibrated)."""
    value = (_made_by(repo, version).get("predicted_accuracy") or {}).get("rms_position_mm")
    return float(value) if isinstance(value, int | float) else None


def _start_version(repo: Repository, robot_id: str, version: int | None) -> ParameterVersion:
    if version is None:
        return repo.version(robot_id)
    latest = repo.latest_version(robot_id)
    if version > latest:
        raise InvalidInput(
            f"start_version {version} does not exist: robot {robot_id!r} has versions 1 to {latest}",
            field="start_version",
        )
    return repo.version(robot_id, version)


def list_calibrations(*, db: Database, robot_id: str, limit: int, offset: int) -> list[CalibrationPublic]:
    with db.reader() as s:
        return [calibration_public(r) for r in Repository(s).calibrations(robot_id, limit, offset)]


def get_calibration(*, db: Database, calibration_id: str) -> CalibrationPublic:
    with db.reader() as s:
        return calibration_public(Repository(s).calibration(calibration_id))
