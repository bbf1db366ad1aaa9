"""Program compensation: POST a KRL, RAPID, URScript or CSV program, get it back with its targets corrected.

The body is JSON (`ProgramRequest`), or the program itself as text (`text/plain`, any `text/*`, or
`application/octet-stream`) with `?format=` or `?filename=` (its extension names the format) and `?version=`.
Either may be sent as a job (`?async=true`: 202, its result the same answer), as a program over the synchronous
budget must be (422 `work-too-large` says so)."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request, Response
from fastapi.exceptions import RequestValidationError

from service.compute import limits
from service.compute.dispatch import BodyComputation, computed
from service.http.deps import ComputeDep, DatabaseDep, JobsDep, ModelCacheDep, RegistryDep
from service.http.guards import OFFLOOP_BYTES
from service.http.json_bodies import OffloopRoute, raw_json_body, request_body, validate_json
from service.http.operations import PROGRAM_COMPENSATION, Runs, operation, program_targets
from service.http.responses import model_json
from service.http.security import Scope
from service.schemas.jobs import JobAccepted
from service.schemas.programs import ProgramFormat, ProgramRequest, ProgramResponse
from service.services import programs
from service.services.jobs import ENCODING, submit_job

router = APIRouter(prefix="/v1/robots/{robot_id}", tags=["programs"], route_class=OffloopRoute)


def _estimate(body: ProgramRequest) -> limits.Estimate:
    """The program and its files by their targets and their bytes (reading costs by the text)."""
    texts = [body.program.encode(), *(text.encode() for text in body.files.values())]
    return limits.program_compensation(sum(program_targets(t) for t in texts), sum(len(t) for t in texts))


COMPENSATE = BodyComputation("program_compensation", ProgramRequest, programs.compensate, estimate=_estimate)
TEXT_TYPES = ("text/", "application/octet-stream")


_RESPONSES: dict[int | str, dict[str, Any]] = {
    202: {"model": JobAccepted, "description": "Accepted as a job (?async=true)"},
    429: {"description": "Job queue full"},
}


@router.post(
    "/programs/compensate",
    response_model=ProgramResponse,
    responses=_RESPONSES,
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
@operation(Scope.read, runs=Runs.COMPUTE, precount=PROGRAM_COMPENSATION, job="program_compensation")
async def compensate(
    robot_id: str,
    *,
    request: Request,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    jobs: JobsDep,
    compute: ComputeDep,
    format: ProgramFormat | None = Query(default=None, description="The format of a program sent as text"),
    filename: str | None = Query(
        default=None, max_length=255, description="Its file name (the extension names the format)"
    ),
    version: int | None = Query(default=None, ge=1, description="The parameter version (default: the current one)"),
    run_async: bool = Query(
        False,
        alias="async",
        description="Run as a job: 202 with a job id; the job's result is the answer (progress per batch of targets)",
    ),
) -> Response:
    kind = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    text = kind.startswith(TEXT_TYPES)
    if run_async:
        body, encoding = await (_text_body(request, format, filename, version) if text else _json_body(request))
        # Over the cap of any job (time or memory) it is refused here, before it is stored.
        compute.admit(_estimate(body), run_async=True)
        accepted = submit_job(
            db=db,
            jobs=jobs,
            kind="program_compensation",
            robot_id=robot_id,
            body=body,
            extra=None if encoding is None else {ENCODING: encoding},
        )
        return model_json(accepted, status_code=202)
    on_robot: dict[str, Any] = {"db": db, "models": models, "registry": registry, "robot_id": robot_id}
    if not text:
        out = await computed(compute, COMPENSATE, request, **on_robot)
        return Response(out, media_type="application/json")
    raw = await request.body()
    # The guard counts JSON bodies (the operation's precount); a text body is counted here, before it is parsed.
    compute.admit(limits.program_compensation(program_targets(raw), len(raw)), run_async=False)
    program = {"raw": raw, "format_name": format, "filename": filename, "version": version}
    answer = await compute(COMPENSATE.kind, programs.compensate_text, **program, **on_robot)
    return Response(answer.model_dump_json(), media_type="application/json")


async def _json_body(request: Request) -> tuple[ProgramRequest, str | None]:
    """A JSON body to store as a job's request, validated as the route's model (a large one in the parse process,
    as `service.http.json_bodies` does for the declared bodies)."""
    raw = await raw_json_body(request)
    pool = getattr(request.app.state, "compute", None)
    parsed = (
        await pool.call(validate_json, ProgramRequest, raw)
        if pool is not None and len(raw) > OFFLOOP_BYTES
        else validate_json(ProgramRequest, raw)
    )
    if isinstance(parsed, list):
        raise RequestValidationError(parsed)
    return parsed, None


async def _text_body(
    request: Request, format_name: str | None, filename: str | None, version: int | None
) -> tuple[ProgramRequest, str | None]:
    """A program sent as text, to store as a job's request: decoded and its format named now, so a body the job
    could never read is refused at once (`programs.request_from_text`); with the encoding it was read in."""
    raw = await request.body()
    if not raw:
        raise RequestValidationError([{"type": "missing", "loc": ("body",), "msg": "Field required"}])
    return programs.request_from_text(raw, format_name=format_name, filename=filename, version=version)
