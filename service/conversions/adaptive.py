"""Adaptive campaigns between the models' values (internal units) and the contract (mm, degrees), and the JSON
their rows keep."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models import RobotDescription
from models._types import Array
from models.campaign import Campaign
from models.errors import InvalidInput
from optimal_design.adaptive import AdaptiveSettings, Pool, Step
from service.conversions.calibrations import records_in
from service.conversions.kinematics import joints_out
from service.conversions.units import instrument_noise
from service.persistence.tables import AdaptiveCampaignRecord, AdaptiveStepRecord
from service.record_kinds.tracker import Record
from service.schemas.adaptive import (
    AdaptiveCampaignCreate,
    AdaptiveCampaignPublic,
    AdaptiveCampaignSummaryPublic,
    AdaptiveStepPublic,
    BlunderPublic,
    EstimatePublic,
    PoseToMeasurePublic,
    PredictedPublic,
)
from service.schemas.cells import DesignCellPublic


def settings_in(request: dict[str, Any]) -> AdaptiveSettings:
    """The models' settings from the stored request (AdaptiveCampaignCreate's JSON)."""
    body = AdaptiveCampaignCreate.model_validate(request)
    return AdaptiveSettings(
        target_mm=body.target_mm,
        target_key=body.target,
        budget=body.budget,
        measurement=body.measurement,
        criterion=body.criterion,
        candidate_count=body.candidate_count,
        seed=body.seed,
        noise=instrument_noise(body.noise.position_mm, body.noise.orientation_deg),
        blunder_sigma=body.blunder_sigma,
    )


def campaign_in(desc: RobotDescription, records: list[dict[str, Any]], settings: AdaptiveSettings) -> Campaign:
    """Every record posted so far as one campaign of the campaign's kind: a position campaign ignores an
    orientation; a pose campaign refuses a record without one (422 naming it)."""
    parsed = [Record.model_validate(r) for r in records]
    if settings.kind.position_only:
        parsed = [r.model_copy(update={"orientation": None}) for r in parsed]
    else:
        missing = next((i for i, r in enumerate(parsed) if r.orientation is None), None)
        if missing is not None:
            raise InvalidInput(
                f"record {missing} has no orientation, and this campaign measures the pose: give each record's "
                'orientation, or start a campaign with "measurement": "position"',
                field="measurements",
                value=missing,
            )
    if not parsed:
        n = desc.n_joints
        quats = None if settings.kind.position_only else np.empty((0, 4))
        return Campaign(np.empty((0, n)), np.empty((0, 3)), quats)
    return records_in(desc, parsed, default_sigma_mm=settings.noise.position_mm)


def pool_document(pool: Pool, cell_version: int | None = None) -> dict[str, Any]:
    """The pool as stored; in a cell, also what the cell checked and refused (`cell`, DesignCellPublic's form)."""
    cell = None
    if pool.in_cell:
        refused = dict(pool.excluded)
        # every candidate sampled went to the cell's check (a campaign has no joint sub-ranges or keep-out box)
        feasible = pool.offered - sum(refused.values())
        cell = {"version": cell_version, "checked": pool.offered, "feasible": feasible, "refused": refused}
    return {
        "joints": pool.joints.tolist(),
        "initial": list(pool.initial),
        "reachable_mm": pool.reachable_mm,
        "excluded": dict(pool.excluded),
        "offered": pool.offered,
        "cell": cell,
    }


def pool_in(document: dict[str, Any]) -> Pool:
    """The stored pool (a campaign stored before cells had none: `offered` and `cell` absent)."""
    joints = np.asarray(document["joints"], dtype=float)
    initial, reachable = tuple(document["initial"]), float(document["reachable_mm"])
    in_cell = document.get("cell") is not None
    return Pool(joints, initial, reachable, dict(document["excluded"]), document.get("offered", 0), in_cell)


def next_document(step: Step) -> list[dict[str, Any]]:
    """The poses asked for next (internal units), each with its pool index or the blunder it replaces."""
    out = []
    blunders = iter(step.replaces)
    for joints, index in zip(step.next_joints.tolist(), step.next_pool, strict=True):
        replaces = next(blunders) if index < 0 else None
        out.append({"joints": joints, "candidate": None if index < 0 else index, "replaces": replaces})
    return out


def state_document(step: Step, asked: tuple[int, ...], records: int) -> dict[str, Any]:
    return {
        "status": "done" if step.done else "measuring",
        "estimate": None if step.estimate is None else np.asarray(step.estimate).tolist(),
        "excluded": sorted(step.excluded),
        "asked": list(asked),
        "next": next_document(step),
        "predicted": step.predicted,
        "reason": step.reason,
        "records": records,
    }


def step_document(step: Step, *, number: int, posted: int, records: int, seconds: float) -> dict[str, Any]:
    """A step's answer as stored (the poses next in internal units: `step_public` converts them)."""
    result = step.result
    estimate = None
    if result is not None:
        after = result.residuals_after
        estimate = EstimatePublic(
            status=result.status.value,
            estimated=len(result.estimated),
            rms_residual_mm=_finite(after.rms_mm),
            max_residual_mm=_finite(after.max_mm),
            variance_factor=_finite(result.variance_factor),
            noise_consistent=bool(result.noise_consistent),
        ).model_dump(mode="json")
    return {
        "number": number,
        "posted": posted,
        "records": records,
        "identified": step.identified,
        "estimate": estimate,
        "predicted": step.predicted,
        "blunders": [vars(b) for b in step.blunders],
        "excluded": sorted(step.excluded),
        "next": next_document(step),
        "done": step.done,
        "reason": step.reason,
        "seconds": seconds,
    }


def _finite(value: float) -> float | None:
    """None where the fit leaves a figure undefined (a variance factor without degrees of freedom)."""
    return float(value) if math.isfinite(value) else None


def _poses(desc: RobotDescription, stored: list[dict[str, Any]]) -> list[PoseToMeasurePublic]:
    if not stored:
        return []
    rows = joints_out(desc, np.asarray([p["joints"] for p in stored], dtype=float))
    return [
        PoseToMeasurePublic(joints=row, candidate=p["candidate"], replaces=p["replaces"])
        for row, p in zip(rows, stored, strict=True)
    ]


def step_public(desc: RobotDescription, document: dict[str, Any], row: AdaptiveStepRecord | None) -> AdaptiveStepPublic:
    predicted = document["predicted"]
    return AdaptiveStepPublic(
        number=document["number"],
        posted=document["posted"],
        records=document["records"],
        identified=document["identified"],
        estimate=None if document["estimate"] is None else EstimatePublic.model_validate(document["estimate"]),
        predicted=None if predicted is None else PredictedPublic.model_validate(predicted),
        blunders=[BlunderPublic.model_validate(b) for b in document["blunders"]],
        excluded=document["excluded"],
        next=_poses(desc, document["next"]),
        done=document["done"],
        reason=document["reason"],
        seconds=document["seconds"],
        created_at=None if row is None else row.created_at,
    )


def campaign_public(
    desc: RobotDescription, row: AdaptiveCampaignRecord, steps: list[AdaptiveStepRecord]
) -> AdaptiveCampaignPublic:
    state = row.state
    return AdaptiveCampaignPublic(
        **_settings_and_state(row),
        cell=_cell(row.pool.get("cell")),
        candidates=len(row.pool["joints"]),
        reachable_mm=row.pool["reachable_mm"],
        next=_poses(desc, state["next"]) if state["status"] == "measuring" else [],
        steps=[step_public(desc, s.result, s) for s in steps],
    )


def campaign_summary(row: AdaptiveCampaignRecord) -> AdaptiveCampaignSummaryPublic:
    """The list's row: read from the campaign's request and state alone (no step, no pool read)."""
    return AdaptiveCampaignSummaryPublic(**_settings_and_state(row), steps=row.steps)


def _settings_and_state(row: AdaptiveCampaignRecord) -> dict[str, Any]:
    """What a campaign's full answer and its list row both say: its settings and where it stands."""
    request, state = row.request, row.state
    predicted = state["predicted"]
    return {
        "id": row.id,
        "robot_id": row.robot_id,
        "version": row.version,
        "status": state["status"],
        "target_mm": request["target_mm"],
        "target": request["target"],
        "budget": request["budget"],
        "measurement": request["measurement"],
        "criterion": request["criterion"],
        "records": state["records"],
        "predicted": None if predicted is None else PredictedPublic.model_validate(predicted),
        "excluded": state["excluded"],
        "reason": state["reason"],
        "calibration_id": row.calibration_id,
        "created_at": row.created_at,
        "updated_at": row.updated_at,
    }


def _cell(stored: dict[str, Any] | None) -> DesignCellPublic | None:
    return None if stored is None else DesignCellPublic.model_validate(stored)


def estimate_in(state: dict[str, Any]) -> Array | None:
    return None if state["estimate"] is None else np.asarray(state["estimate"], dtype=float)
