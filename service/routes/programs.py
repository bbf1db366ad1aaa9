"""Program compensation: POST a KRL, RAPID, URScript or CSV program, get it back with its targets corrected.

The body is JSON (`ProgramRequest`), or the program itself as text (`text/plain`, any `text/*`, or
`application/octet-stream`) with `?format=` or `?filename=` (its extension names the format) and `?version=`."""

from __future__ import annotations

from fastapi import APIRouter, Query, Request, Response

from service import limits
from service.deps import DatabaseDep, MetricsDep, ModelCacheDep, RegistryDep, compute
from service.dispatch import BodyComputation, computed
from service.json_bodies import OffloopRoute, request_body
from service.operations import PROGRAM_COMPENSATION, Runs, operation, program_targets
from service.schemas.programs import ProgramFormat, ProgramRequest, ProgramResponse
from service.security import Scope
from service.services import programs

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["programs"], route_class=OffloopRoute)


def _estimate(body: ProgramRequest) -> limits.Estimate:
    """The program and its files by their targets and their bytes (reading costs by the text)."""
    texts = [body.program.encode(), *(text.encode() for text in body.files.values())]
    return limits.program_compensation(sum(program_targets(t) for t in texts), sum(len(t) for t in texts))


COMPENSATE = BodyComputation("program_compensation", ProgramRequest, programs.compensate, estimate=_estimate)
TEXT_TYPES = ("text/", "application/octet-stream")


@router.post(
    "/programs/compensate",
    response_model=ProgramResponse,
    openapi_extra={
        "requestBody": {
            "required": True,
            "content": {
                **request_body(ProgramRequest)["requestBody"]["content"],
                "text/plain": {"schema": {"type": "string"}},
            },
        }
    },
)
@operation(Scope.read, runs=Runs.COMPUTE, precount=PROGRAM_COMPENSATION)
async def compensate(
    robot_id: str,
    *,
    request: Request,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    m: MetricsDep,
    format: ProgramFormat | None = Query(default=None, description="The format of a program sent as text"),
    filename: str | None = Query(
        default=None, max_length=255, description="Its file name (the extension names the format)"
    ),
    version: int | None = Query(default=None, ge=1, description="The parameter version (default: the current one)"),
) -> Response:
    kind = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    if not kind.startswith(TEXT_TYPES):
        out = await computed(m, COMPENSATE, request, db=db, models=models, registry=registry, robot_id=robot_id)
        return Response(out, media_type="application/json")
    raw = await request.body()
    # The guard counts JSON bodies (the operation's precount); a text body is counted here, before it is parsed.
    budget = request.app.state.settings.sync_budget_seconds
    estimate = limits.program_compensation(program_targets(raw), len(raw))
    limits.admit(estimate, run_async=False, can_run_async=False, budget_s=budget)
    answer = await compute(
        m,
        COMPENSATE.kind,
        programs.compensate_text,
        raw=raw,
        format_name=format,
        filename=filename,
        version=version,
        db=db,
        models=models,
        registry=registry,
        robot_id=robot_id,
    )
    return Response(answer.model_dump_json(), media_type="application/json")
