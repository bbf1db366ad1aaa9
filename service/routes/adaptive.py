"""Adaptive campaigns: start, post records, read, finish (docs/api.md, docs/pose-design.md)."""

from __future__ import annotations

from fastapi import APIRouter, Response

from service.compute import limits
from service.http.deps import ActorDep, ComputeDep, DatabaseDep, ModelCacheDep, RegistryDep
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.schemas.adaptive import (
    AdaptiveCampaignCreate,
    AdaptiveCampaignPublic,
    AdaptiveCampaignSummaryPublic,
    AdaptiveFinish,
    AdaptiveRecordsCreate,
    AdaptiveStepPublic,
)
from service.services import adaptive

router = APIRouter(tags=["adaptive campaigns"], route_class=OffloopRoute)
_PATH = "/v1/robots/{robot_id}/adaptive-campaigns"


@router.post(_PATH, status_code=201, response_model=AdaptiveCampaignPublic)
@operation(Scope.write, runs=Runs.COMPUTE)
async def create_adaptive_campaign(
    robot_id: str,
    body: AdaptiveCampaignCreate,
    *,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    """A campaign that asks for one pose at a time, re-identifies after each record and stops when the
    predicted accuracy reaches the target (or the budget is spent): its candidate pool and the first poses to
    measure (the identifiable minimum and two spare, D-optimal). With a cell, only poses it can measure."""
    # no job form: a start over the synchronous budget (a cell's checks of many candidates) asks for fewer
    cost = limits.adaptive_start(body.candidate_count, in_cell=body.cell is not None)
    kwargs = {"db": db, "models": models, "registry": registry, "robot_id": robot_id, "body": body}
    result = await compute.admitted(cost, "adaptive", adaptive.create_campaign, **kwargs)
    return model_json(result, status_code=201)


@router.post(_PATH + "/{campaign_id}/records", response_model=AdaptiveStepPublic)
@operation(Scope.write, runs=Runs.COMPUTE)
async def post_adaptive_records(
    robot_id: str,
    campaign_id: str,
    body: AdaptiveRecordsCreate,
    *,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    """Records measured (tracker records, as a calibration takes them): the updated estimate, the predicted
    accuracy, the blunders flagged, and the next pose or `done` with why. With an Idempotency-Key a retry replays
    the answer instead of posting the records twice."""
    kwargs = {"db": db, "models": models, "registry": registry, "robot_id": robot_id, "campaign_id": campaign_id}
    result = await compute("adaptive", adaptive.post_records, body=body, **kwargs)
    return model_json(result)


robot_list(
    router,
    _PATH,
    AdaptiveCampaignSummaryPublic,
    adaptive.list_campaigns,
    name="list_adaptive_campaigns",
    doc="""The robot's adaptive campaigns, oldest first: each one's settings, status, records and predicted accuracy
    (its steps by its id).""",
)


@router.get(_PATH + "/{campaign_id}", response_model=AdaptiveCampaignPublic)
@operation(Scope.read)
def get_adaptive_campaign(robot_id: str, campaign_id: str, db: DatabaseDep, models: ModelCacheDep) -> Response:
    """The campaign's state and every step."""
    return model_json(adaptive.get_campaign(db=db, models=models, robot_id=robot_id, campaign_id=campaign_id))


@router.post(_PATH + "/{campaign_id}/finish", response_model=AdaptiveCampaignPublic)
@operation(Scope.write, runs=Runs.COMPUTE)
async def finish_adaptive_campaign(
    robot_id: str,
    campaign_id: str,
    *,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    actor: ActorDep,
    compute: ComputeDep,
    body: AdaptiveFinish | None = None,
) -> Response:
    """End the campaign; by default store a calibration of its records (blunders left out) through the
    calibration path, whose checks decide whether it is applied."""
    kwargs = {"db": db, "models": models, "registry": registry, "robot_id": robot_id, "campaign_id": campaign_id}
    result = await compute("adaptive", adaptive.finish_campaign, body=body or AdaptiveFinish(), actor=actor, **kwargs)
    return model_json(result)
