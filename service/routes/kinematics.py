from __future__ import annotations

from fastapi import APIRouter, Request, Response

from models import Registry
from service import limits
from service.csv_codec import joints_csv
from service.deps import MetricsDep, ModelCacheDep, RegistryDep, compute, wants_csv
from service.json_bodies import OffloopRoute
from service.model_cache import ModelCache
from service.responses import model_json
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse
from service.services import kinematics

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["kinematics"], route_class=OffloopRoute)


INLINE_POSES = 16
"""Up to this many poses (≈0.3 ms with the cached model) run on the event loop: a hop to a worker thread,
and the GIL hand-over it implies, would cost more than the work."""


def _forward_json(*, models: ModelCache, registry: Registry, robot_id: str, body: ForwardRequest) -> bytes:
    # Serialised in the compute process: the JSON travels back, not a model to unpickle and serialise here
    # (1 000 poses: 0.16 s as a model on a loaded machine).
    out = kinematics.forward(models=models, registry=registry, robot_id=robot_id, body=body)
    return bytes(out.__pydantic_serializer__.to_json(out))


def _inverse_json(*, models: ModelCache, registry: Registry, robot_id: str, body: InverseRequest) -> bytes:
    out = kinematics.inverse(models=models, registry=registry, robot_id=robot_id, body=body)
    return bytes(out.__pydantic_serializer__.to_json(out))


@router.post("/forward-kinematics", response_model=ForwardResponse)
async def forward(
    robot_id: str, body: ForwardRequest, models: ModelCacheDep, registry: RegistryDep, m: MetricsDep
) -> Response:
    if len(body.joints) <= INLINE_POSES:
        return model_json(kinematics.forward(models=models, registry=registry, robot_id=robot_id, body=body))
    limits.admit(limits.forward_kinematics(len(body.joints)), run_async=False, can_run_async=False)
    out = await compute(
        m, "forward_kinematics", _forward_json, models=models, registry=registry, robot_id=robot_id, body=body
    )
    return Response(out, media_type="application/json")


@router.post(
    "/inverse-kinematics",
    response_model=InverseResponse,
    responses={200: {"content": {"text/csv": {"schema": {"type": "string"}}}}},
)
async def inverse(
    robot_id: str,
    *,
    body: InverseRequest,
    request: Request,
    models: ModelCacheDep,
    registry: RegistryDep,
    m: MetricsDep,
) -> Response:
    limits.admit(limits.inverse_kinematics(len(body.targets)), run_async=False, can_run_async=False)
    if not wants_csv(request):
        raw = await compute(
            m, "inverse_kinematics", _inverse_json, models=models, registry=registry, robot_id=robot_id, body=body
        )
        return Response(raw, media_type="application/json")
    out = await compute(
        m, "inverse_kinematics", kinematics.inverse, models=models, registry=registry, robot_id=robot_id, body=body
    )
    names = models.current(robot_id)[0].joint_names
    return Response(joints_csv(out.joints, names), media_type="text/csv")
