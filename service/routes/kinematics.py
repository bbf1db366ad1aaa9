from __future__ import annotations

from fastapi import APIRouter, Request, Response

from service import limits
from service.csv_codec import joints_csv
from service.deps import MetricsDep, ModelCacheDep, compute, wants_csv
from service.responses import model_json
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse
from service.services import kinematics

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["kinematics"])


INLINE_POSES = 16
"""Up to this many poses (≈0.3 ms with the cached model) run on the event loop: a hop to a worker thread,
and the GIL hand-over it implies, would cost more than the work."""


@router.post("/forward-kinematics", response_model=ForwardResponse)
async def forward(robot_id: str, body: ForwardRequest, models: ModelCacheDep, m: MetricsDep) -> Response:
    if len(body.joints) <= INLINE_POSES:
        return model_json(kinematics.forward(models=models, robot_id=robot_id, body=body))
    limits.admit(limits.forward_kinematics(len(body.joints)), run_async=False, can_run_async=False)
    out = await compute(m, "forward_kinematics", kinematics.forward, models=models, robot_id=robot_id, body=body)
    return model_json(out)


@router.post(
    "/inverse-kinematics",
    response_model=InverseResponse,
    responses={200: {"content": {"text/csv": {"schema": {"type": "string"}}}}},
)
async def inverse(
    robot_id: str, body: InverseRequest, request: Request, models: ModelCacheDep, m: MetricsDep
) -> Response:
    limits.admit(limits.inverse_kinematics(len(body.targets)), run_async=False, can_run_async=False)
    out = await compute(m, "inverse_kinematics", kinematics.inverse, models=models, robot_id=robot_id, body=body)
    if wants_csv(request):
        names = models.current(robot_id)[0].joint_names
        return Response(joints_csv(out.joints, names), media_type="text/csv")
    return model_json(out)
