"""Calibrations: the request as a campaign, noise and options; the frozen `IdentificationResult` as the report."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from models import RobotDescription
from models._types import Array
from models.campaign import Campaign, make_campaign
from models.identification import IdentificationOptions
from models.identification.acceptance import Check
from models.identification.result import IdentificationResult, Outlier, PredictedAccuracy, ResidualSummary
from models.noise import NoiseModel
from service.conversions.kinematics import joints_in
from service.conversions.references import references_out
from service.conversions.terms import record_conditions
from service.conversions.units import instrument_noise
from service.errors import BadRequest
from service.persistence.tables import CalibrationRecord
from service.record_kinds.tracker import Record
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic, CalibrationReportPublic
from service.schemas.common import Payload, timestamp


def records_in(
    desc: RobotDescription,
    measurements: Sequence[Record],
    *,
    default_sigma_mm: float | None = None,
    payload: Payload | None = None,
) -> Campaign:
    """A whole campaign of the models from records of one kind that make one (`RecordKind.measurement_kinds`: a
    tracker's; `service.services.pipelines`), checked."""
    with_orientation = [r.orientation is not None for r in measurements]
    if any(with_orientation) and not all(with_orientation):
        first = with_orientation.index(not with_orientation[0])
        raise BadRequest(
            f"record {first}: either every record has an orientation or none has (position-only campaign)",
            record=first,
        )
    joints = joints_in(desc, [r.joints for r in measurements])
    positions = np.array([r.position for r in measurements], dtype=float)
    quats = np.array([r.orientation for r in measurements], dtype=float) if all(with_orientation) else None
    given = [r.sigma_mm for r in measurements]
    sigma = None
    if any(g is not None for g in given) and default_sigma_mm is not None:
        sigma = [default_sigma_mm if g is None else g for g in given]  # the rest: the campaign's σ
    conditions = record_conditions(desc, measurements, payload)
    return make_campaign(desc, joints, positions, quats, sigma_mm=sigma, conditions=conditions)


def noise_in(body: CalibrationCreate) -> NoiseModel:
    return instrument_noise(body.noise.position_mm, body.noise.orientation_deg)


def options_in(body: CalibrationCreate) -> IdentificationOptions:
    options = body.options
    return IdentificationOptions(
        estimate=tuple(options.estimate), robust=options.robust, robust_scale=options.robust_scale
    )


def _degrees(radians: float | None) -> float | None:
    return None if radians is None else math.degrees(radians)


def _residual_orientation_deg(summary: ResidualSummary) -> tuple[float | None, float | None, Array | None]:
    per_pose = None if summary.per_pose_rad is None else np.degrees(summary.per_pose_rad)
    return _degrees(summary.rms_rad), _degrees(summary.max_rad), per_pose


def _outlier_orientation_deg(outlier: Outlier) -> float | None:
    return _degrees(outlier.orientation_rad)


def _accuracy_orientation_deg(accuracy: PredictedAccuracy) -> tuple[float, float]:
    return math.degrees(accuracy.rms_orientation_rad), math.degrees(accuracy.max_orientation_rad)


def _residuals(summary: ResidualSummary) -> dict[str, Any]:
    rms_deg, max_deg, per_pose_deg = _residual_orientation_deg(summary)
    xyz = summary.per_pose_xyz_mm
    return {
        "rms_mm": summary.rms_mm,
        "max_mm": summary.max_mm,
        "rms_deg": rms_deg,
        "max_deg": max_deg,
        "per_pose_mm": summary.per_pose_mm.tolist(),
        "per_pose_deg": None if per_pose_deg is None else per_pose_deg.tolist(),
        "rms_xyz_mm": None if xyz is None else np.sqrt(np.mean(xyz**2, axis=0)).tolist(),
        "per_pose_xyz_mm": None if xyz is None else xyz.tolist(),
    }


def report_out(
    desc: RobotDescription,
    result: IdentificationResult,
    *,
    start_values: Array,
    start_version: int,
    checks: tuple[Check, ...] = (),
    noise: NoiseModel | None = None,
    drift: dict[str, Any] | None = None,
    conditions: dict[str, Any] | None = None,
) -> CalibrationReportPublic:
    """The whole report, boundary units. `nominal` is the robot's nominal geometry and `start` the start
    version's values (the fit's `result.nominal`), so a re-fit shows both."""
    # Long on purpose: one report document built field by field: its sections read as the schema declares them.
    table = desc.parameters
    chosen = set(result.estimated)
    value = table.as_boundary(result.parameters).tolist()
    nominal = table.as_boundary(table.nominal).tolist()
    start = table.as_boundary(start_values).tolist()
    std = table.as_boundary(result.std_errors).tolist()
    rms_orientation_deg, max_orientation_deg = _accuracy_orientation_deg(result.predicted_accuracy)
    accuracy = result.predicted_accuracy
    solver = result.solver
    return CalibrationReportPublic.model_validate(
        {
            "status": result.status,
            "reason": result.reason,
            "parameters": [
                {
                    "name": name,
                    "value": value[i],
                    "unit": table.units[i],
                    "nominal": nominal[i],
                    "std_error": std[i] if i in chosen else None,
                    "identifiable": i in chosen,
                    "start": start[i],
                }
                for i, name in enumerate(table.names)
            ],
            "identifiable": list(result.identifiable_names),
            "unidentifiable": list(result.unidentifiable_names),
            "confounding": {
                c.name: [{"with": partner, "coefficient": k} for partner, k in c.partners] for c in result.confounding
            },
            "correlated_pairs": [{"a": a, "b": b, "correlation": r} for a, b, r in result.correlated_pairs],
            "rank": result.rank,
            "condition_number": result.condition_number,
            "identifiability_rechecked": result.identifiability_rechecked,
            "residuals": {"before": _residuals(result.residuals_before), "after": _residuals(result.residuals_after)},
            "variance_factor": result.variance_factor,
            "degrees_of_freedom": result.dof,
            "noise_consistent": result.noise_consistent,
            "outliers": [
                {
                    "pose": o.pose,
                    "position_mm": o.position_mm,
                    "orientation_deg": _outlier_orientation_deg(o),
                    "statistic": o.statistic,
                    "threshold": o.threshold,
                    "excluded": o.excluded,
                }
                for o in result.outliers
            ],
            "solver": {
                "name": solver.name,
                "status": solver.status,
                "success": solver.success,
                "iterations": solver.iterations,
                "seconds": solver.seconds,
                "evaluations": solver.evaluations,
                "polish_steps": solver.polish_steps,
            },
            "predicted_accuracy": {
                "rms_position_mm": accuracy.rms_position_mm,
                "max_position_mm": accuracy.max_position_mm,
                "rms_orientation_deg": rms_orientation_deg,
                "max_orientation_deg": max_orientation_deg,
                "workspace_poses": accuracy.poses,
                "measured_region_rms_position_mm": accuracy.region_rms_position_mm,
                "measured_region_max_position_mm": accuracy.region_max_position_mm,
                "measured_region_record_rms_mm": accuracy.region_record_rms_mm,
                "extrapolation": accuracy.extrapolation,
            },
            "measurement": result.kind.value,
            "measurements": result.measurements,
            "seconds": result.seconds,
            "notes": list(result.notes),
            "start_version": start_version,
            "diagnoses": diagnoses_out(result),
            "checks": [
                {"name": c.name, "passed": c.passed, "detail": c.detail, "blocks_apply": c.blocking} for c in checks
            ],
            "correlation": _correlation(result),
            "noise": None
            if noise is None
            else {"position_mm": noise.position_mm, "orientation_deg": math.degrees(noise.orientation_rad)},
            "references": references_out(result.references),
            "frame": result.frame,
            "record_kinds": dict(result.record_kinds) or None,
            "drift": drift,
            "conditions": conditions,
        }
    )


def diagnoses_out(result: IdentificationResult) -> list[dict[str, Any]]:
    return [
        {"finding": d.finding.value, "message": d.message, "records": list(d.records), "blocking": d.blocking}
        for d in result.diagnoses
    ]


def _correlation(result: IdentificationResult) -> dict[str, Any] | None:
    """cov_ij / (σ_i σ_j) of the estimated parameters (unit-free, so internal units are fine)."""
    cov = np.asarray(result.covariance, dtype=float)
    if cov.ndim != 2 or cov.shape[0] != len(result.estimated) or cov.shape[0] == 0:
        return None
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        matrix = np.clip(cov / np.outer(sd, sd), -1.0, 1.0)
    return {"names": list(result.identifiable_names), "matrix": matrix.tolist()}


PREDICTION_KEY = "prediction_covariance"
"""The stored document's key for the covariance predictions at fresh poses use (`forward-kinematics` with
accuracy): kept with the calibration, never shown (internal units, and the correlation says it publicly)."""


def stored_document(report: CalibrationReportPublic, result: IdentificationResult) -> dict[str, Any]:
    """What a calibration's row keeps: its public report, and the covariance predictions use."""
    document = report.model_dump(mode="json")
    cov = result.prediction_covariance
    if cov is not None and cov.size and cov.shape == (len(result.estimated), len(result.estimated)):
        document[PREDICTION_KEY] = {"names": list(result.identifiable_names), "matrix": cov.tolist()}
    return document


def stored_prediction(document: dict[str, Any]) -> tuple[list[str], Array] | None:
    """(parameter names, covariance in internal units) a calibration's document keeps for predictions; None for
    one stored before it was kept, or whose fit gave none."""
    found = document.get(PREDICTION_KEY)
    if not found:
        return None
    return list(found["names"]), np.asarray(found["matrix"], dtype=float)


def calibration_public(record: CalibrationRecord) -> CalibrationPublic:
    """The stored report with the row's columns. Validated again on the way out: a calibration stored before a
    field existed gets its default, as the declared response model gave it."""
    return CalibrationPublic.model_validate(
        {
            **{key: value for key, value in record.result.items() if key != PREDICTION_KEY},
            "id": record.id,
            "robot_id": record.robot_id,
            "campaign_id": record.campaign_id,
            "status": record.status,
            "applied": record.applied,
            "parameter_version": record.parameter_version,
            "start_version": record.start_version,
            "created_at": timestamp(record.created_at),
            "user_notes": record.notes,
            "instrument": record.instrument,
        }
    )
