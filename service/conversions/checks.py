"""Quick checks: the domain `CheckResult` as the stored document (boundary units), the stored row as the contract's
`QuickCheckPublic`, a check design's poses, and the history's events."""

from __future__ import annotations

from typing import Any

import numpy as np

from models import RobotDescription
from models.checks import CheckAction, CheckResult, Explanation, Recommendation
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


def history_out(calibrations: list[CalibrationRecord], checks: list[CheckRecord]) -> list[HistoryEventPublic]:
    """One timeline, oldest first: each calibration (its status, applied or not) and each check (its verdict)."""
    events = [
        (
            c.created_at,
            {
                "kind": "calibration",
                "id": c.id,
                "version": c.parameter_version,
                "outcome": f"{c.status}, {'applied' if c.applied else 'not applied'}",
            },
        )
        for c in calibrations
    ] + [(k.created_at, {"kind": "check", "id": k.id, "version": k.version, "outcome": k.verdict}) for k in checks]
    events.sort(key=lambda e: (e[0], e[1]["id"]))
    return [HistoryEventPublic.model_validate({"at": timestamp(at), **e}) for at, e in events]
