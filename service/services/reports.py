"""A calibration's report, built from what the API serves: the stored calibration document, its campaign's measured
positions, the stored correlation matrix and the validations of the version it produced."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from service.conversions.calibrations import calibration_public
from service.conversions.checks import history_out
from service.conversions.validations import validation_public
from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle
from service.record_kinds import kind_of
from service.services.checks import HISTORY_MAX

if TYPE_CHECKING:
    from service.reports import CalibrationReport


def build_report(*, db: Database, calibration_id: str) -> CalibrationReport:
    # The report package loads with its first report: matplotlib is 0.9 s of every process's start-up otherwise.
    from service.reports import CalibrationReport  # noqa: PLC0415

    with db.reader() as s:
        repo, life = Repository(s), Lifecycle(s)
        record = repo.calibration(calibration_id)
        # The report reads the document as a client does: the answer's JSON.
        document = calibration_public(record).model_dump(mode="json")
        robot_name = repo.robot(record.robot_id).name
        records = life.campaign(record.campaign_id).records
        # A figure of measured positions needs every record to have one (distances and touches have none).
        measured = [kind_of(r).measured_position(r) for r in records]
        positions = None if any(p is None for p in measured) else np.array(measured, dtype=float)
        produced = record.parameter_version
        validations: list[dict[str, Any]] = []
        if produced is not None:
            for row in life.validations(record.robot_id):
                doc = validation_public(row).model_dump(mode="json")
                results = [r for r in doc["results"] if r["version"] == produced]
                if results:
                    validations.append({**doc, "results": results})
        events = history_out(
            repo.calibrations(record.robot_id, HISTORY_MAX, 0), life.checks(record.robot_id, HISTORY_MAX, 0)
        )
        history = [e.model_dump(mode="json") for e in events]
    stored = document.get("correlation")
    correlation = None
    if stored:
        matrix = np.array([[np.nan if v is None else v for v in row] for row in stored["matrix"]], dtype=float)
        correlation = (list(stored["names"]), matrix)
    noise = document.get("noise") or {}
    return CalibrationReport(
        calibration=document,
        robot_name=robot_name,
        measured_positions=positions,
        correlation=correlation,
        noise_position_mm=noise.get("position_mm"),
        validations=validations,
        history=history,
    )


def report_html(*, db: Database, calibration_id: str) -> str:
    from service.reports import render_html  # noqa: PLC0415

    return render_html(build_report(db=db, calibration_id=calibration_id))


def report_pdf(*, db: Database, calibration_id: str) -> bytes:
    from service.reports import render_pdf  # noqa: PLC0415

    return render_pdf(build_report(db=db, calibration_id=calibration_id))
