from __future__ import annotations

from fastapi import APIRouter, Response
from pydantic import TypeAdapter

from service import limits
from service.deps import DatabaseDep, Limit, MetricsDep, Offset, RegistryDep, SettingsDep, compute
from service.json_bodies import OffloopRoute
from service.operations import VALIDATION, Runs, operation
from service.responses import model_json, models_json
from service.schemas.validations import IsoPosesCreate, IsoPosesPublic, ValidationCreate, ValidationPublic
from service.security import Scope
from service.services import validations

router = APIRouter(tags=["validations"], route_class=OffloopRoute)
_VALIDATIONS = TypeAdapter(list[ValidationPublic])


@router.post("/v1/robots/{robot_id}/validations", status_code=201, response_model=ValidationPublic)
@operation(Scope.write, runs=Runs.COMPUTE, precount=VALIDATION)
async def create_validation(
    robot_id: str,
    body: ValidationCreate,
    *,
    db: DatabaseDep,
    registry: RegistryDep,
    m: MetricsDep,
    settings: SettingsDep,
) -> Response:
    """Measurements that are not fitted, against parameter versions: per-pose errors, RMS, max, percentiles, and
    ISO 9283 AP/RP (and AD/RD) where joint commands repeat."""
    # A large body was counted in its bytes (its precount); a small one can still ask for much (600 records × 50
    # versions), counted here. No job form: over the budget, fewer at a time.
    records = len(body.measurements)
    cost = limits.validation(records * len(body.versions or [None]), records)
    limits.admit(cost, run_async=False, can_run_async=False, budget_s=settings.sync_budget_seconds)
    result = await compute(
        m, "validation", validations.validate, db=db, registry=registry, robot_id=robot_id, body=body
    )
    return model_json(result, status_code=201)


@router.get("/v1/robots/{robot_id}/validations", response_model=list[ValidationPublic])
@operation(Scope.read)
def list_validations(
    robot_id: str,
    db: DatabaseDep,
    limit: Limit = 100,
    offset: Offset = 0,
) -> Response:
    return models_json(validations.list_validations(db=db, robot_id=robot_id, limit=limit, offset=offset), _VALIDATIONS)


@router.get("/v1/validations/{validation_id}", response_model=ValidationPublic)
@operation(Scope.read)
def get_validation(validation_id: str, db: DatabaseDep) -> Response:
    return model_json(validations.get_validation(db=db, validation_id=validation_id))


@router.post("/v1/robots/{robot_id}/iso9283-poses", response_model=IsoPosesPublic)
@operation(Scope.read, runs=Runs.COMPUTE)  # computes the cube's commands, stores nothing
async def iso9283_poses(
    robot_id: str, db: DatabaseDep, registry: RegistryDep, m: MetricsDep, body: IsoPosesCreate | None = None
) -> Response:
    """The ISO 9283 test cube inside the workspace (C1…C8, P1…P5) and the joint commands of P1…P5 from the
    chosen version (default: current). Measure P1…P5 in cycles and POST them as a validation."""
    chosen = body or IsoPosesCreate()
    result = await compute(
        m, "iso9283", validations.iso_poses, db=db, registry=registry, robot_id=robot_id, body=chosen
    )
    return model_json(result)
