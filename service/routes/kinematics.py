from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError

from models import Registry
from service import limits
from service.csv_codec import joints_csv
from service.deps import MetricsDep, ModelCacheDep, RegistryDep, compute, wants_csv
from service.guards import OFFLOOP_BYTES
from service.json_bodies import OffloopRoute, raw_json_body, request_body, validate_json, validated
from service.model_cache import ModelCache
from service.operations import FORWARD_KINEMATICS, INVERSE_KINEMATICS, Runs, operation
from service.responses import model_json
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse
from service.security import Scope
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


def _forward_raw(*, models: ModelCache, registry: Registry, robot_id: str, raw: bytes) -> bytes | list[Any]:
    # A large body travels as its bytes and is validated here, in the compute process: as a model it would be
    # unpickled in the API process, holding the GIL its loop needs (20 000 vectors: 30-55 ms a request).
    body = validate_json(ForwardRequest, raw)
    return (
        body
        if isinstance(body, list)
        else _forward_json(models=models, registry=registry, robot_id=robot_id, body=body)
    )


def _inverse(*, models: ModelCache, registry: Registry, robot_id: str, body: InverseRequest, as_json: bool) -> Any:
    out = kinematics.inverse(models=models, registry=registry, robot_id=robot_id, body=body)
    return bytes(out.__pydantic_serializer__.to_json(out)) if as_json else out


def _inverse_raw(*, models: ModelCache, registry: Registry, robot_id: str, raw: bytes, as_json: bool) -> Any:
    # A large body validated here, in the compute process (see _forward_raw).
    body = validate_json(InverseRequest, raw)
    if isinstance(body, list):
        return body
    return _inverse(models=models, registry=registry, robot_id=robot_id, body=body, as_json=as_json)


def _answer(out: Any) -> Any:
    if isinstance(out, list):  # the body's validation errors, found in the compute process
        raise RequestValidationError(out)
    return out


@router.post("/forward-kinematics", response_model=ForwardResponse, openapi_extra=request_body(ForwardRequest))
@operation(Scope.read, runs=Runs.COMPUTE, precount=FORWARD_KINEMATICS)
async def forward(
    robot_id: str, request: Request, models: ModelCacheDep, registry: RegistryDep, m: MetricsDep
) -> Response:
    raw = await raw_json_body(request)
    if len(raw) > OFFLOOP_BYTES:  # counted and admitted from the bytes (its `precount`, service.operations)
        out = await compute(
            m, "forward_kinematics", _forward_raw, models=models, registry=registry, robot_id=robot_id, raw=raw
        )
        return Response(_answer(out), media_type="application/json")
    body = validated(ForwardRequest, raw)
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
    m: MetricsDep,
) -> Response:
    raw = await raw_json_body(request)
    csv = wants_csv(request)
    if len(raw) > OFFLOOP_BYTES:  # counted and admitted from the bytes (its `precount`, service.operations)
        fn: Callable[..., Any] = _inverse_raw
        given: dict[str, Any] = {"raw": raw}
    else:  # validated here, once: the compute process gets the model
        body = validated(InverseRequest, raw)
        limits.admit(limits.inverse_kinematics(len(body.targets)), run_async=False, can_run_async=False)
        fn, given = _inverse, {"body": body}
    out = _answer(
        await compute(
            m, "inverse_kinematics", fn, models=models, registry=registry, robot_id=robot_id, as_json=not csv, **given
        )
    )
    if not csv:
        return Response(out, media_type="application/json")
    names = models.current(robot_id)[0].joint_names
    return Response(joints_csv(out.joints, names), media_type="text/csv")
