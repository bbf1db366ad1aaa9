"""Quick checks: the domain `CheckResult` as the stored document (boundary units), the stored row as the contract's
`QuickCheckPublic`, a check design's poses, and the history's events."""

from __future__ import annotations

import csv
import io
import math
from typing import Any

import numpy as np

from models import RobotDescription
from models.evaluation.checks import CheckAction, CheckResult, Explanation, Recommendation
from models.measurement import MeasurementKind
from optimal_design.checks import CheckDesign
from service.conversions.kinematics import joints_out
from service.conversions.validations import measured_document
from service.persistence.tables import CalibrationRecord, CheckRecord
from service.schemas.checks import Against, HistoryEventPublic, QuickCheckDesignPublic, QuickCheckPublic
from service.schemas.common import timestamp


def _explanation_out(desc: RobotDescription, e: Explanation) -> dict[str, Any]:
    table = desc.parameters
    factor = table.to_boundary[list(e.parameters)]
    return {
        "name": e.name,
        "parameters": [
            {
                "name": table.names[i],
                "unit": table.units[i],
                "change": float(e.change[k] * factor[k]),
                "std_error": float(e.std_error[k] * factor[k]),
                "calibrated_std_error": float(e.prior_sigma[k] * factor[k]),
            }
            for k, i in enumerate(e.parameters)
        ],
        "chi2_after": e.chi2,
        "dof_after": e.dof,
        "reduction": e.reduction,
        "p_value": e.p_value,
        "explains": e.explains,
    }


def _message(recommendation: Recommendation) -> str:
    if recommendation.action is CheckAction.NONE:
        return "nothing to do: the records agree with the version within its predicted uncertainty"
    if recommendation.action is CheckAction.REFIT:
        names = ", ".join(recommendation.parameters)
        return (
            f"re-fit {names} from {recommendation.poses} designed poses (POST a calibration estimating them, "
            "started from the current version)"
        )
    return f"calibrate the robot again: measure {recommendation.poses} designed poses"


def check_document(
    desc: RobotDescription, version: int, against: Against, result: CheckResult, *, kind: MeasurementKind, size: int
) -> dict[str, Any]:
    """What is stored of a check: the response's fields but the row's own columns."""
    rec = result.recommendation
    return {
        "version": version,
        "against": against,
        "verdict": result.verdict.value,
        "statistic": {
            "chi2": result.chi2,
            "dof": result.dof,
            "threshold": result.threshold,
            "p_value": result.p_value,
            "alpha": result.alpha,
        },
        "registered": result.registered,
        "measurement": kind.value,
        "measurements": size,
        "per_record": [
            {"position_mm": float(e), "predicted_mm": float(p)}
            for e, p in zip(result.position_mm, result.predicted_mm, strict=True)
        ],
        "explanation": None if result.explanation is None else _explanation_out(desc, result.explanation),
        "alternatives": [_explanation_out(desc, e) for e in result.alternatives],
        "recommendation": {
            "action": rec.action.value,
            "parameters": list(rec.parameters),
            "poses": rec.poses,
            "message": _message(rec),
        },
        "seconds": result.seconds,
    }


HISTORY_COLUMNS = ("at", "kind", "id", "version", "outcome", "rms_mm", "predicted_mm", "drift_mm")


def history_csv(events: list[HistoryEventPublic]) -> str:
    """The timeline as CSV (one row an event, the JSON's fields as columns; empty where null)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(HISTORY_COLUMNS)
    for e in events:
        row = e.model_dump(mode="json")
        writer.writerow(["" if row[c] is None else row[c] for c in HISTORY_COLUMNS])
    return out.getvalue()


def check_public(record: CheckRecord) -> QuickCheckPublic:
    return QuickCheckPublic.model_validate(measured_document(record))


def check_design_out(
    desc: RobotDescription, robot_id: str, version: int, design: CheckDesign, *, position_only: bool, registered: bool
) -> QuickCheckDesignPublic:
    table = desc.parameters
    detectable = design.detectable * table.to_boundary[list(design.watched)]
    return QuickCheckDesignPublic.model_validate(
        {
            "robot_id": robot_id,
            "version": version,
            "measurement": "position" if position_only else "pose",
            "registered": registered,
            "poses": [{"joints": row} for row in joints_out(desc, design.joints)],
            "watched": [
                {"name": table.names[i], "unit": table.units[i], "detectable": float(d) if np.isfinite(d) else None}
                for i, d in zip(design.watched, detectable, strict=True)
            ],
            "criterion": design.value,
            "candidates": design.candidates,
        }
    )


def _number(value: object) -> float | None:
    return float(value) if isinstance(value, int | float) and math.isfinite(value) else None


def _rms(values: list[float]) -> float | None:
    return float(np.sqrt(np.mean(np.square(values)))) if values else None


def _calibration_accuracy(document: dict[str, Any]) -> dict[str, float | None]:
    """A stored calibration's residual RMS after the fit, predicted accuracy and drift (None where absent)."""
    after = (document.get("residuals") or {}).get("after") or {}
    predicted = document.get("predicted_accuracy") or {}
    drift = document.get("drift") or {}
    return {
        "rms_mm": _number(after.get("rms_mm")),
        "predicted_mm": _number(predicted.get("rms_position_mm")),
        "drift_mm": _number(drift.get("magnitude_mm")),
    }


def _check_accuracy(document: dict[str, Any]) -> dict[str, float | None]:
    records = document.get("per_record") or []
    return {
        "rms_mm": _rms([r["position_mm"] for r in records]),
        "predicted_mm": _rms([r["predicted_mm"] for r in records]),
    }


def history_out(calibrations: list[CalibrationRecord], checks: list[CheckRecord]) -> list[HistoryEventPublic]:
    """One timeline, oldest first: each calibration (its status, applied or not) and each check (its verdict),
    with the accuracy measured and expected then."""
    events = [
        (
            c.created_at,
            {
                "kind": "calibration",
                "id": c.id,
                "version": c.parameter_version,
                "outcome": f"{c.status}, {'applied' if c.applied else 'not applied'}",
                **_calibration_accuracy(c.result),
            },
        )
        for c in calibrations
    ] + [
        (
            k.created_at,
            {"kind": "check", "id": k.id, "version": k.version, "outcome": k.verdict, **_check_accuracy(k.result)},
        )
        for k in checks
    ]
    events.sort(key=lambda e: (e[0], e[1]["id"]))
    return [HistoryEventPublic.model_validate({"at": timestamp(at), **e}) for at, e in events]
