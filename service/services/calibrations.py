from __future__ import annotations

import numpy as np

from models import Registry
from models.errors import InvalidInput
from models.identifiability import structural_identifiability
from models.identification import IdentificationOptions, identify
from models.identification.acceptance import acceptance_checks, decide
from service.audit_actions import AuditAction
from service.conversions.calibrations import (
    calibration_public,
    campaign_in,
    diagnoses_out,
    noise_in,
    options_in,
    report_out,
)
from service.conversions.robots import description
from service.conversions.terms import padded, requested_model
from service.conversions.terms import start_values as start_values_for
from service.errors import CalibrationFailed, Conflict
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle, check_revision
from service.persistence.repository import new_id
from service.persistence.tables import ParameterVersion
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic
from service.services.hooks import JobHooks


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
    with db.reader() as s:
        repo = Repository(s)
        check_revision(repo.robot(robot_id), if_match)
        # The terms of `options.terms` (a 422 naming it for a robot without the parts they act on); the start
        # version's values for what it has, the terms' nominal values for what it has not.
        desc = requested_model(description(repo.robot(robot_id)), body.options.terms)
        start_row = _start_version(repo, robot_id, body.start_version)
        start_version = start_row.version
        stored_values = np.asarray(start_row.values, dtype=float)
        start_values = start_values_for(desc, stored_values)
        same = stored_values.size == desc.n_params
        start_std = padded(list(start_row.std_errors or []) if same else [], desc.n_params, None)
        start_ident = padded(list(start_row.identifiable or []) if same else [], desc.n_params, False)
        start_accuracy = _predicted_accuracy(repo, start_row)
    campaign = campaign_in(desc, body)
    options = options_in(body)
    if job is not None:
        job.progress("identifying", 0.05)
    # The fit starts from the chosen version, so whatever it does not estimate keeps that version's calibrated
    # values (a base-only re-fit after the tracker moved must not send the links and legs back to nominal).
    noise = noise_in(body)
    runtime = registry.runtime(desc)
    result = identify(desc, campaign, noise=noise, nominal=start_values, options=options, runtime=runtime)
    candidates = desc.parameters.indices(options.estimate)
    expected = structural_identifiability(desc, candidates, campaign.kind, runtime=runtime).rank
    everything = structural_identifiability(
        desc, desc.parameters.indices(IdentificationOptions().estimate), campaign.kind, runtime=runtime
    )
    partial = expected < everything.rank  # parameters held at the start version's (calibrated) values
    checks = acceptance_checks(
        result,
        expected_rank=expected,
        start_accuracy_mm=start_accuracy,
        sigma_mm=body.noise.position_mm,
        held_accuracy_mm=start_accuracy if partial else None,
    )
    decision = decide(checks, succeeded=result.succeeded, requested=body.apply, force=body.force_apply)
    report = report_out(
        desc, result, start_values=start_values, start_version=start_version, checks=checks, noise=noise
    )
    records = [r.model_dump() for r in body.measurements]
    calibration_id = new_id()
    if job is not None:
        job.progress("storing", 0.95)
    won_by: int | None = None
    with db.session() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id, lock=True)  # still there, and one calibration at a time per robot
        if decision.apply and robot.current_version != start_version:
            # Optimistic concurrency: another writer made a version while this fit ran (or the fit started
            # from an older one). Applying would silently discard that version's work; keep this one stored.
            won_by = robot.current_version
            decision = decision.superseded(_lost_race(calibration_id, start_version, won_by))
        stored = repo.add_campaign(robot_id, records)
        document = report.model_copy(
            update={
                "notes": [*body.import_notes, *report.notes],
                "not_applied_reason": decision.reason,
                "forced": decision.forced,
            }
        )
        record = repo.add_calibration(
            calibration_id, robot_id, stored.id, result.status, document.model_dump(mode="json")
        )
        record.start_version = start_version
        record.notes = body.notes
        record.instrument = None if body.instrument is None else body.instrument.model_dump()
        if decision.apply:
            # What this fit estimated carries its new statistics; the rest keeps the start version's.
            std, ident = start_std, start_ident
            for i in result.estimated:
                value = float(result.std_errors[i])
                std[i], ident[i] = (value if np.isfinite(value) else None), True
            previous = robot.current_version
            who = actor or Actor()
            record.parameter_version = Lifecycle(s).add_version(
                robot,
                values=result.parameters.tolist(),
                std_errors=std,
                identifiable=ident,
                provenance="calibration",
                actor=who,
                calibration_id=calibration_id,
            )
            record.applied = True
            Lifecycle(s).changed(
                robot,
                AuditAction.VERSION_CALIBRATED,
                who,
                version=record.parameter_version,
                # `forced` only when it was: an applied calibration that failed a check (force_apply).
                details={"from_version": previous, "calibration_id": calibration_id}
                | ({"forced": True} if decision.forced else {}),
            )
        if job is not None and result.succeeded:
            # The job's `succeeded` joins this transaction (a calibration that lost the race is stored, not
            # applied: its job did its work, the reason is in the result); a failed fit ends the job `failed`
            # below, with the same problem the synchronous request answers.
            job.commit(s, calibration_id)
        answer = calibration_public(record)
    if not result.succeeded:
        raise CalibrationFailed(
            f"the calibration failed and was not applied: {result.reason} (stored as calibration {calibration_id})",
            calibration_id=calibration_id,
            diagnoses=diagnoses_out(result),
        )
    if won_by is not None and job is None:  # after the commit: the calibration is stored, only not applied
        raise Conflict(
            _lost_race(calibration_id, start_version, won_by),
            calibration_id=calibration_id,
            start_version=start_version,
            current_version=won_by,
        )
    return answer


def _lost_race(calibration_id: str, start_version: int, won_by: int) -> str:
    """The conflict's words: the synchronous request's 409 detail, and a job's `not_applied_reason`."""
    return (
        f"conflict: calibration {calibration_id} is stored but not applied: it started from parameter version "
        f"{start_version}, and version {won_by} became current meanwhile; review both, then calibrate "
        f"again from version {won_by} or restore the one you want"
    )


def _predicted_accuracy(repo: Repository, version: ParameterVersion) -> float | None:
    """The start version's predicted RMS TCP accuracy, from the calibration that made it (None: uncalibrated)."""
    if version.calibration_id is None:
        return None
    made_by = repo.calibration(version.calibration_id).result.get("predicted_accuracy") or {}
    value = made_by.get("rms_position_mm")
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
