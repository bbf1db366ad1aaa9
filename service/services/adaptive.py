"""Adaptive campaigns (optimal_design.adaptive): start one, post its records step by step, read it, finish it.

Every step is stored with the campaign's state after it (the estimate, the excluded records, the poses asked for
and the next ones), and the candidate pool is stored once: a step reads all of it back, so a service restarted
mid-campaign answers the next post as the one before would have. Read, compute outside any transaction, write
in one; a post that raced another for the same step is refused (409) rather than stored twice.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

from sqlalchemy.orm import Session

from models import Registry
from models.measurement import MeasurementKind
from optimal_design.adaptive import Pool, Progress, advance
from service.compute.model_cache import ModelCache
from service.conversions.adaptive import (
    campaign_in,
    campaign_public,
    campaign_summary,
    estimate_in,
    pool_document,
    pool_in,
    settings_in,
    state_document,
    step_document,
    step_public,
)
from service.errors import Conflict
from service.persistence import Database, Repository
from service.persistence.adaptive import AdaptiveStore
from service.persistence.lifecycle import Actor
from service.persistence.tables import AdaptiveCampaignRecord
from service.record_kinds.tracker import Record
from service.schemas.adaptive import (
    AdaptiveCampaignCreate,
    AdaptiveCampaignPublic,
    AdaptiveCampaignSummaryPublic,
    AdaptiveFinish,
    AdaptiveRecordsCreate,
    AdaptiveStepPublic,
)
from service.schemas.calibrations import CalibrationCreate
from service.services import calibrations
from service.services.cells import used_cell


def create_campaign(
    *, db: Database, models: ModelCache, registry: Registry, robot_id: str, body: AdaptiveCampaignCreate
) -> AdaptiveCampaignPublic:
    """The campaign, its pool and first poses (or, with starting records, its first step) as stored."""
    started = time.perf_counter()
    desc, theta = models.current(robot_id)
    with db.reader() as s:
        version = Repository(s).version(robot_id).version
    request = body.model_dump(mode="json", exclude={"measurements"})
    settings = settings_in(request)
    cell = None
    if body.cell is not None:
        # the pool is checked once, here: every pose the campaign asks for later is one of it
        cell = used_cell(db=db, models=models, registry=registry, robot_id=robot_id, cell=body.cell)
        settings = replace(settings, cell=cell.cell)
    runtime = registry.runtime(desc)
    pool = Pool.build(desc, settings, params=theta, runtime=runtime)
    records = [r.model_dump(mode="json") for r in body.measurements or []]
    progress = Progress(campaign_in(desc, records, settings), estimate=theta)
    step = advance(desc, pool, settings, progress, runtime=runtime)
    asked = tuple(i for i in step.next_pool if i >= 0)
    with db.session() as s:
        Repository(s).robot(robot_id, lock=True)  # still there
        store = AdaptiveStore(s)
        pool_json = pool_document(pool, None if cell is None else cell.version)
        row = store.add(robot_id, version, request, pool_json, state_document(step, asked, len(records)))
        if records:
            seconds = time.perf_counter() - started
            document = step_document(step, number=1, posted=len(records), records=len(records), seconds=seconds)
            store.add_step(row, 0, records, document)
        return campaign_public(desc, row, store.steps(row.id))


def post_records(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    campaign_id: str,
    body: AdaptiveRecordsCreate,
) -> AdaptiveStepPublic:
    """The step these records make: re-identified, blunders flagged, the predicted accuracy and what is next."""
    started = time.perf_counter()
    desc, _ = models.current(robot_id)
    with db.reader() as s:
        row, before = _measuring_records(s, robot_id, campaign_id)
        request, state, pool_json, expected = row.request, dict(row.state), row.pool, row.steps
    settings = settings_in(request)
    posted = [r.model_dump(mode="json") for r in body.measurements]
    records = before + posted
    progress = Progress(
        campaign_in(desc, records, settings),
        excluded=frozenset(state["excluded"]),
        estimate=estimate_in(state),
        asked=tuple(state["asked"]),
    )
    step = advance(desc, pool_in(pool_json), settings, progress, runtime=registry.runtime(desc))
    asked = progress.asked + tuple(i for i in step.next_pool if i >= 0 and i not in progress.asked)
    seconds = time.perf_counter() - started
    document = step_document(step, number=expected + 1, posted=len(posted), records=len(records), seconds=seconds)
    with db.session() as s:
        store = AdaptiveStore(s)
        row = store.campaign(robot_id, campaign_id, lock=True)
        stored = store.add_step(row, expected, posted, document)
        row.state = state_document(step, asked, len(records))
        return step_public(desc, document, stored)


def _measuring_records(
    s: Session, robot_id: str, campaign_id: str
) -> tuple[AdaptiveCampaignRecord, list[dict[str, Any]]]:
    """The campaign, still measuring (a 409 once it is finished or ended), and every record its steps took."""
    store = AdaptiveStore(s)
    row = store.campaign(robot_id, campaign_id)
    _measuring(row)
    return row, [r for step in store.steps(row.id) for r in step.records]


def _measuring(row: AdaptiveCampaignRecord) -> None:
    status = row.state["status"]
    if status in ("finished", "ended"):
        raise Conflict(
            f"adaptive campaign {row.id} is {status}: it takes no more records (start another)",
            id=row.id,
        )


def get_campaign(*, db: Database, models: ModelCache, robot_id: str, campaign_id: str) -> AdaptiveCampaignPublic:
    desc, _ = models.current(robot_id)
    with db.reader() as s:
        store = AdaptiveStore(s)
        row = store.campaign(robot_id, campaign_id)
        return campaign_public(desc, row, store.steps(row.id))


def list_campaigns(*, db: Database, robot_id: str, limit: int, offset: int) -> list[AdaptiveCampaignSummaryPublic]:
    with db.reader() as s:
        Repository(s).robot(robot_id)  # a 404 for a robot that is not there, not an empty list
        return [campaign_summary(row) for row in AdaptiveStore(s).campaigns(robot_id, limit, offset)]


def finish_campaign(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    campaign_id: str,
    body: AdaptiveFinish,
    actor: Actor | None = None,
) -> AdaptiveCampaignPublic:
    """End the campaign; with `calibrate`, first store a calibration of its records (blunders left out) through
    the calibration path, so its checks (never worse, apply) hold as for any other."""
    desc, _ = models.current(robot_id)
    with db.reader() as s:
        row, records = _measuring_records(s, robot_id, campaign_id)
        request, state = row.request, row.state
    calibration_id = None
    if body.calibrate:
        calibration_id = calibrations.calibrate(
            db=db,
            registry=registry,
            robot_id=robot_id,
            body=_calibration_body(records, request, state, body),
            actor=actor,
        ).id
    with db.session() as s:
        store = AdaptiveStore(s)
        row = store.campaign(robot_id, campaign_id, lock=True)
        _measuring(row)
        row.state = {**row.state, "status": "finished" if body.calibrate else "ended"}
        row.calibration_id = calibration_id
        return campaign_public(desc, row, store.steps(row.id))


def _calibration_body(
    records: list[dict[str, Any]], request: dict[str, Any], state: dict[str, Any], body: AdaptiveFinish
) -> CalibrationCreate:
    """The campaign's records but the blunders, as a calibration request (a position campaign's without their
    orientations), with the campaign's noise."""
    excluded = set(state["excluded"])
    kept = [Record.model_validate(r) for i, r in enumerate(records) if i not in excluded]
    if MeasurementKind.parse(request["measurement"]).position_only:
        kept = [r.model_copy(update={"orientation": None}) for r in kept]
    return CalibrationCreate.model_validate(
        {
            "measurements": [r.model_dump(mode="json", exclude_none=True) for r in kept],
            "noise": request["noise"],
            "apply": body.apply,
            "notes": body.notes,
        }
    )
