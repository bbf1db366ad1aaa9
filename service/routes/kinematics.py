from __future__ import annotations

from fastapi import APIRouter, Request, Response

from service.compute import limits
from service.compute.dispatch import BodyComputation, computed
from service.files.csv_codec import joints_csv
from service.http.deps import ComputeDep, ModelCacheDep, RegistryDep, wants_csv
from service.http.json_bodies import OffloopRoute, request_body
from service.http.operations import FORWARD_KINEMATICS, INVERSE_KINEMATICS, Runs, operation
from service.http.security import Scope
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse
from service.services import kinematics

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["kinematics"], route_class=OffloopRoute)


INLINE_POSES = 16
"""Up to this many poses (≈0.3 ms with the cached model) run on the event loop: a hop to a worker thread,
and the GIL hand-over it implies, would cost more than the work."""

FORWARD = BodyComputation(
    "forward_kinematics",
    ForwardRequest,
    kinematics.forward,
    estimate=lambda body: limits.forward_kinematics(len(body.joints)),
    # A prediction reads the calibration's campaign once per version: never on the event loop.
    inline=lambda body: len(body.joints) <= INLINE_POSES and not body.accuracy,
)
INVERSE = BodyComputation(
    "inverse_kinematics",
    InverseRequest,
    kinematics.inverse,
    estimate=lambda body: limits.inverse_kinematics(len(body.targets)),
)


@router.post("/forward-kinematics", response_model=ForwardResponse, openapi_extra=request_body(ForwardRequest))
@operation(Scope.read, runs=Runs.COMPUTE, precount=FORWARD_KINEMATICS)
async def forward(
    robot_id: str, request: Request, models: ModelCacheDep, registry: RegistryDep, compute: ComputeDep
) -> Response:
    out = await computed(compute, FORWARD, request, models=models, registry=registry, robot_id=robot_id)
    return Response(out, media_type="application/json")


@router.post(
    "/inverse-kinematics",
    response_model=InverseResponse,
    openapi_extra=request_body(InverseRequest),
    responses={200: {"content": {"text/csv": {"schema": {"type": "string"}}}}},
)
@operation(Scope.read, runs=Runs.COMPUTE, precount=INVERSE_KINEMATICS)
async def inverse(
    robot_id: str,
    *,
    request: Request,
    models: ModelCacheDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    csv = wants_csv(request)
    out = await computed(
        compute, INVERSE, request, as_json=not csv, models=models, registry=registry, robot_id=robot_id
    )
    if not csv:
        return Response(out, media_type="application/json")
    names = models.current(robot_id)[0].joint_names
    return Response(joints_csv(out.joints, names), media_type="text/csv")
