from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Annotated, Any, Literal

import anyio
from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.exceptions import RequestValidationError
from pydantic import TypeAdapter, ValidationError
from python_multipart.exceptions import MultipartParseError

from service import limits
from service.campaign_io import ImportOptions, QuaternionOrder
from service.csv_codec import CAMPAIGN_HEADER, joined_campaign, parse_campaign
from service.deps import ActorDep, DatabaseDep, JobsDep, Limit, MetricsDep, Offset, RegistryDep, compute, negotiate
from service.errors import BadRequest, UnsupportedMediaType
from service.guards import OFFLOOP_BYTES
from service.json_bodies import OffloopRoute
from service.operations import CALIBRATION, Runs, operation
from service.responses import model_json, models_json
from service.routes.robots import IfMatch
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic
from service.security import Scope
from service.services import calibrations
from service.services.jobs import submit_job

router = APIRouter(tags=["calibrations"], route_class=OffloopRoute)
# Stored reports are validated as `CalibrationPublic` where the service reads them (service.conversions), so the
# contract holds for every answer; `model_json` then serialises that model once instead of FastAPI validating it
# a second time.
_CALIBRATIONS = TypeAdapter(list[CalibrationPublic])

_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {"schema": {"$ref": "#/components/schemas/CalibrationCreate"}},
            "text/csv": {
                "schema": {"type": "string", "description": "header " + ",".join(CAMPAIGN_HEADER)},
                "example": ",".join(CAMPAIGN_HEADER) + "\n400,150,90,45,420,420,420,420,420,420,1,2,3,1,0,0,0\n",
            },
            "multipart/form-data": {
                "schema": {
                    "type": "object",
                    "required": ["joints", "points"],
                    "properties": {
                        "joints": {"type": "string", "format": "binary", "description": "pose id + joint columns"},
                        "points": {
                            "type": "string",
                            "format": "binary",
                            "description": "pose id + x, y, z (CSV, Leica-style) or a SpatialAnalyzer export",
                        },
                        "points_format": {"type": "string", "enum": ["csv", "spatial-analyzer"], "default": "csv"},
                    },
                }
            },
        },
    },
    "responses": {
        "202": {
            "description": "Accepted as a job (?async=true)",
            "content": {"application/json": {"schema": {"$ref": "#/components/schemas/JobAccepted"}}},
        },
        "406": {"description": "The Accept header allows no JSON (a calibration is a JSON document)"},
        "412": {"description": "If-Match is stale"},
        "429": {"description": "Job queue full"},
    },
}


@dataclass(frozen=True)
class CampaignQuery:
    """What the query adds to a campaign sent as a file (CSV or multipart), where the body has no field for it;
    `apply` overrides a JSON body's too."""

    apply: bool | None
    noise_position_mm: float | None
    noise_orientation_deg: float | None
    file_options: ImportOptions
    terms: list[str] | None
    payload_kg: float | None
    payload_cog_mm: list[float] | None


def campaign_query(
    *,
    apply: bool | None = Query(None, description="Override the body's 'apply' (useful with CSV)"),
    noise_position_mm: float | None = Query(None, gt=0, le=1000, description="σ position, CSV bodies"),
    noise_orientation_deg: float | None = Query(None, gt=0, le=180, description="σ orientation, CSV bodies"),
    length_unit: Literal["mm", "m", "cm", "um", "in"] = Query(
        "mm", description="CSV bodies: unit of x, y, z and sigma where the header does not state one ('X [m]')"
    ),
    quaternion_order: QuaternionOrder = Query(
        QuaternionOrder.WXYZ, description="CSV bodies: of q0…q3 columns (Leica-style); qw/qx/qy/qz name themselves"
    ),
    terms: list[Literal["thermal", "compliance"]] | None = Query(
        None, description="CSV bodies: options.terms (the temperature_c column feeds the thermal term)"
    ),
    payload_kg: float | None = Query(None, ge=0, le=10_000, description="CSV bodies: the campaign's payload mass"),
    payload_cog_mm: list[float] | None = Query(
        None, min_length=3, max_length=3, description="CSV bodies: its centre of gravity x, y, z (tool frame, mm)"
    ),
) -> CampaignQuery:
    return CampaignQuery(
        apply,
        noise_position_mm,
        noise_orientation_deg,
        ImportOptions(length_unit=length_unit, quaternion_order=quaternion_order),
        list(terms) if terms else None,
        payload_kg,
        payload_cog_mm,
    )


async def _body(request: Request, query: CampaignQuery) -> CalibrationCreate:
    """The campaign as JSON, as one CSV, or as the controller's joint file and the instrument's point file
    (multipart: `joints`, `points`, optional `points_format`), with noise and apply from the query."""
    content_type = request.headers.get("content-type", "application/json").split(";")[0].strip().lower()
    raw = await request.body()
    try:
        if content_type in ("text/csv", "multipart/form-data"):
            if content_type == "text/csv":
                text = _text(raw, "the CSV body")
                # Off the event loop, like the JSON body below: a large file parses for seconds.
                measurements, notes = await request.app.state.compute.call(
                    functools.partial(parse_campaign, text, options=query.file_options)
                )
            else:
                measurements, notes = await _files(request, query.file_options)
            payload: dict[str, Any] = {"measurements": measurements, "import_notes": notes}
            noise = {}
            if query.noise_position_mm is not None:
                noise["position_mm"] = query.noise_position_mm
            if query.noise_orientation_deg is not None:
                noise["orientation_deg"] = query.noise_orientation_deg
            if noise:
                payload["noise"] = noise
            if query.apply is not None:
                payload["apply"] = query.apply
            if query.terms:
                payload["options"] = {"terms": query.terms}
            if query.payload_kg is not None:
                payload["payload"] = {"mass_kg": query.payload_kg, "cog_mm": query.payload_cog_mm or [0.0, 0.0, 0.0]}
            return await anyio.to_thread.run_sync(CalibrationCreate.model_validate, payload)
        if content_type in ("application/json", ""):
            # A large body in the parse process (100 000 records validate in 2.2 s here, in a thread holding the
            # GIL the event loop needs); a small one here, where a hop would cost more (64 kB: ~5 ms).
            parsed: CalibrationCreate | list[Any] = (
                await request.app.state.compute.call(_validate_json, raw)
                if len(raw) > OFFLOOP_BYTES
                else _validate_json(raw or b"null")
            )
            if isinstance(parsed, list):
                raise RequestValidationError(parsed)
            return parsed.model_copy(update={"apply": query.apply}) if query.apply is not None else parsed
    except ValidationError as exc:
        raise RequestValidationError(exc.errors(include_url=False, include_context=False)) from exc
    raise UnsupportedMediaType(
        f"send the campaign as application/json or text/csv, not {content_type!r}", content_type=content_type
    )


def _validate_json(raw: bytes) -> CalibrationCreate | list[Any]:
    """The body as a CalibrationCreate, or its validation errors (plain data: this runs in a compute process)."""
    try:
        return CalibrationCreate.model_validate_json(raw)
    except ValidationError as exc:
        return list(exc.errors(include_url=False, include_context=False))


def _json_answer(request: Request) -> None:
    """Refuse up front (406) a client that cannot read the JSON answer, before any computation."""
    negotiate(request, ["application/json", "application/problem+json"])


def _text(raw: bytes, what: str) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise BadRequest(f"{what} must be UTF-8 text") from exc


async def _files(request: Request, options: ImportOptions) -> tuple[list[dict[str, object]], list[str]]:
    """A joint file and a point file (CSV, a Leica-style export, or SpatialAnalyzer's ASCII) joined by pose id."""
    parts = {}
    try:
        async with request.form() as form:  # closes the spooled upload files when done
            for name in ("joints", "points"):
                part = form.get(name)
                if part is None or isinstance(part, str):
                    raise BadRequest(f"multipart campaigns need two files, 'joints' and 'points'; '{name}' is missing")
                parts[name] = _text(await part.read(), f"the '{name}' file")
            points_format = str(form.get("points_format") or "csv")
    except MultipartParseError as exc:
        # Starlette turns its own multipart errors into a 400 but lets the parser's escape (a 500).
        raise BadRequest(f"the multipart body is malformed: {exc}") from exc
    if points_format not in ("csv", "spatial-analyzer"):
        raise BadRequest(f"points_format must be 'csv' or 'spatial-analyzer', not {points_format!r}")
    return joined_campaign(parts["joints"], parts["points"], spatial_analyzer=points_format != "csv", options=options)


@router.post(
    "/v1/robots/{robot_id}/calibrations",
    status_code=201,
    response_model=CalibrationPublic,
    openapi_extra=_BODY,
    dependencies=[Depends(_json_answer)],
)
@operation(Scope.write, runs=Runs.COMPUTE, precount=CALIBRATION, job="calibration")
async def create_calibration(
    robot_id: str,
    request: Request,
    db: DatabaseDep,
    jobs: JobsDep,
    m: MetricsDep,
    *,
    registry: RegistryDep,
    actor: ActorDep,
    run_async: bool = Query(False, alias="async", description="Run as a job: 202 with a job id"),
    query: Annotated[CampaignQuery, Depends(campaign_query)],
    if_match: IfMatch = None,
) -> Response:
    # A JSON body over the budget was refused before any parsing (its `precount`, service.operations); a CSV one is
    # counted once parsed.
    body = await _body(request, query)
    limits.admit(limits.calibration(len(body.measurements)), run_async=run_async)
    if run_async:
        accepted = submit_job(
            db=db, jobs=jobs, kind="calibration", robot_id=robot_id, body=body, actor=actor, if_match=if_match
        )
        return model_json(accepted, status_code=202)
    calibration = await compute(
        m,
        "identification",
        calibrations.calibrate,
        db=db,
        registry=registry,
        robot_id=robot_id,
        body=body,
        actor=actor,
        if_match=if_match,
    )
    return model_json(calibration, status_code=201)


@router.get("/v1/robots/{robot_id}/calibrations", response_model=list[CalibrationPublic])
@operation(Scope.read)
def list_calibrations(
    robot_id: str,
    db: DatabaseDep,
    limit: Limit = 100,
    offset: Offset = 0,
) -> Response:
    return models_json(
        calibrations.list_calibrations(db=db, robot_id=robot_id, limit=limit, offset=offset), _CALIBRATIONS
    )


@router.get(
    "/v1/calibrations/{calibration_id}",
    response_model=CalibrationPublic,
    responses={406: {"description": "The Accept header allows no JSON (its campaign as CSV: /v1/campaigns/{id})"}},
)
@operation(Scope.read)
def get_calibration(calibration_id: str, request: Request, db: DatabaseDep) -> Response:
    # A calibration is a JSON document (its campaign has a CSV form: GET /v1/campaigns/{id}); 406 for anything
    # else rather than JSON a CSV client cannot read.
    negotiate(request, ["application/json"])
    return model_json(calibrations.get_calibration(db=db, calibration_id=calibration_id))
