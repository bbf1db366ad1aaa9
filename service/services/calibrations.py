from __future__ import annotations

from typing import Any

import numpy as np

from models.errors import InvalidInput
from models.identification import identify
from service.conversions.calibrations import calibration_public, campaign_in, noise_in, options_in, report_out
from service.conversions.robots import description
from service.persistence import Database, Repository
from service.persistence.repository import new_id
from service.persistence.tables import ParameterVersion
from service.schemas.calibrations import CalibrationCreate
from service.services.hooks import JobHooks


def calibrate(*, db: Database, robot_id: str, body: CalibrationCreate, job: JobHooks | None = None) -> dict[str, Any]:
    """Identify, then store the campaign, the calibration and (when it succeeded and `apply`) the new version
    together, with the job's own `succeeded` when run as one. The result as `CalibrationPublic` JSON."""
    if job is not None:
        job.progress("reading", 0.0)
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        start_row = _start_version(repo, robot_id, body.start_version)
        start_version = start_row.version
        start_values = np.asarray(start_row.values, dtype=float)
        start_std = list(start_row.std_errors or [None] * len(start_values))
        start_ident = list(start_row.identifiable or [False] * len(start_values))
    campaign = campaign_in(desc, body)
    if job is not None:
        job.progress("identifying", 0.05)
    # The fit starts from the chosen version, so whatever it does not estimate keeps that version's calibrated
    # values (a base-only re-fit after the tracker moved must not send the links and legs back to nominal).
    result = identify(desc, campaign, noise=noise_in(body), nominal=start_values, options=options_in(body))
    report = report_out(desc, result, start_values=start_values, start_version=start_version)
    payload = report.model_dump(mode="json")
    records = [r.model_dump() for r in body.measurements]
    calibration_id = new_id()
    if job is not None:
        job.progress("storing", 0.95)
    with db.session() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id, lock=True)  # still there, and one calibration at a time per robot
        stored = repo.add_campaign(robot_id, records)
        record = repo.add_calibration(calibration_id, robot_id, stored.id, result.status, payload)
        record.start_version = start_version
        if result.succeeded and body.apply:
            # What this fit estimated carries its new statistics; the rest keeps the start version's.
            std, ident = start_std, start_ident
            for i in result.estimated:
                value = float(result.std_errors[i])
                std[i], ident[i] = (value if np.isfinite(value) else None), True
            record.parameter_version = repo.add_version(robot, result.parameters.tolist(), std, ident, calibration_id)
            record.applied = True
        if job is not None:
            job.commit(s, calibration_id)
        return calibration_public(record)


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


def list_calibrations(*, db: Database, robot_id: str, limit: int, offset: int) -> list[dict[str, Any]]:
    with db.reader() as s:
        return [calibration_public(r) for r in Repository(s).calibrations(robot_id, limit, offset)]


def get_calibration(*, db: Database, calibration_id: str) -> dict[str, Any]:
    with db.reader() as s:
        return calibration_public(Repository(s).calibration(calibration_id))
