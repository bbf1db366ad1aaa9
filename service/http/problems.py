"""RFC 9457 problem documents: one table from error classes to HTTP, and one renderer, `to_problem`.

Routes never build HTTP errors by hand: they raise domain errors (`models.errors`) or the service's own
(`service.errors`). The exception handlers, the body-limit middleware and the job runner all turn an exception
into a body with `to_problem`, so a job's stored error is exactly what the synchronous request would have
answered.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from models import errors as domain
from programs import errors as program_errors
from service import errors as service
from service.schemas.structure import STAGE_KINDS

PROBLEM_JSON = "application/problem+json"
TYPE_BASE = "https://iwr-calibration.example/problems/"
RESERVED = frozenset({"type", "title", "status", "detail"})
log = logging.getLogger("service.http.problems")

PROBLEMS: dict[type[Exception], tuple[int, str, str]] = {
    # domain errors: the caller's data
    domain.WrongShape: (422, "wrong-shape", "Wrong shape"),
    domain.NonFiniteValue: (422, "non-finite-value", "Not a finite number"),
    domain.JointOutOfRange: (422, "joint-out-of-range", "Joint outside its range"),
    domain.UnreachablePose: (422, "unreachable-pose", "Pose the robot cannot reach"),
    domain.InvalidQuaternion: (422, "invalid-quaternion", "Not a unit quaternion"),
    domain.TooFewMeasurements: (422, "too-few-measurements", "Too few measurements"),
    domain.TargetUnreachable: (422, "target-unreachable", "Target accuracy unreachable"),
    domain.UnknownParameter: (422, "unknown-parameter", "Unknown parameter or group"),
    domain.FleetTooSmall: (422, "fleet-too-small", "Too few calibrated units in the fleet"),
    domain.PriorMismatch: (422, "prior-mismatch", "A prior of another robot model"),
    program_errors.ProgramSyntaxError: (422, "program-syntax", "Syntax error in the program"),
    program_errors.UndeclaredFrame: (422, "undeclared-frame", "Base or tool not declared"),
    program_errors.ProgramError: (422, "program-error", "Program not understood"),
    domain.InvalidInput: (422, "invalid-input", "Invalid input"),
    domain.NotIdentifiable: (422, "not-identifiable", "Nothing identifiable"),
    domain.InconsistentData: (422, "inconsistent-data", "Data inconsistent with the robot"),
    domain.SolverFailed: (422, "solver-failed", "The solver did not converge"),
    domain.CalibrationError: (422, "calibration-error", "Calibration error"),
    # the service's own
    service.BadRequest: (400, "bad-request", "Bad request"),
    service.CalibrationFailed: (422, "calibration-failed", "The calibration failed"),
    service.Unauthorized: (401, "unauthorized", "API key missing or wrong"),
    service.Forbidden: (403, "forbidden", "Scope too small"),
    service.NotFound: (404, "not-found", "Not found"),
    service.NotAcceptable: (406, "not-acceptable", "Not acceptable"),
    service.PreconditionFailed: (412, "precondition-failed", "Precondition failed"),
    service.Conflict: (409, "conflict", "Conflict"),
    service.IdempotencyKeyReused: (422, "idempotency-key-reused", "Idempotency-Key reused"),
    service.WorkTooLarge: (422, "work-too-large", "Too much work for one request"),
    service.ParseTimeout: (422, "parse-timeout", "The body took too long to read"),
    service.Overloaded: (503, "overloaded", "Overloaded"),
    service.ClientGone: (503, "client-gone", "Client gone"),
    service.RequestTimeout: (408, "request-timeout", "Request timeout"),
    service.PayloadTooLarge: (413, "payload-too-large", "Request body too large"),
    service.UnsupportedMediaType: (415, "unsupported-media-type", "Unsupported media type"),
    service.JobFinished: (409, "job-finished", "Job already finished"),
    service.QueueFull: (429, "queue-full", "Job queue full"),
    service.Interrupted: (503, "interrupted", "Interrupted"),
    service.DatabaseUnavailable: (503, "database-unavailable", "Database unavailable"),
    service.NotReady: (503, "not-ready", "Not ready"),
    service.ServiceError: (500, "service-error", "Service error"),
    # the framework's: request validation, and HTTP errors Starlette raises itself (unknown path, method)
    RequestValidationError: (422, "validation-error", "Invalid request"),
}
HTTP_TITLES: dict[int, str] = {
    404: "Not found",
    405: "Method not allowed",
    406: "Not acceptable",
    415: "Unsupported media type",
}
"""Starlette's HTTP errors keep their `http-<status>` type (what clients have seen since v1)."""
INTERNAL = (500, "internal-error", "Internal error")
MAX_ERRORS = 20
"""Validation errors listed in a problem document; `error_count` says how many there were."""


def lookup(exc: BaseException) -> tuple[int, str, str]:
    """(status, slug, title) of the nearest mapped class; 500 for anything unmapped (a bug, logged)."""
    if isinstance(exc, StarletteHTTPException):
        return exc.status_code, f"http-{exc.status_code}", HTTP_TITLES.get(exc.status_code, "HTTP error")
    for cls in type(exc).__mro__:
        if cls in PROBLEMS:
            return PROBLEMS[cls]
    return INTERNAL


UNION_TAG_ERRORS = ("union_tag_invalid", "union_tag_not_found")
"""Pydantic places a wrong or missing discriminator at the union's location; the field at fault is the tag."""


def _union_member(part: object) -> bool:
    """Whether a location part names the union member pydantic tried rather than a field: a record's tag (the
    record kinds' registry, `service.record_kinds.CampaignRecord`), or pydantic's own label of an untagged member
    (`list[constrained-float]`, `ReferenceCandidate`)."""
    # Imported here, not above: the record kinds raise this module's problems (service.errors).
    from service.record_kinds import RECORD_KINDS  # noqa: PLC0415

    if not isinstance(part, str):
        return False
    return part in RECORD_KINDS or "[" in part or part[:1].isupper()


def field_name(loc: list[Any], error_type: str = "") -> str:
    """A validation error's location as the specs name fields: `measurements[4].temperature_c` in a body, and in
    a robot's description document the document's own path (`stages[0].links[0].joint`, as robots.md and the
    rules of `models.description.structure` name it), without pydantic's `body` prefix or the stage's union tag."""
    parts = list(loc[1:] if loc[:1] == ["body"] else loc)
    if parts[:1] == ["structure"] and len(parts) > 1:
        parts = parts[1:]
    out = ""
    for k, part in enumerate(parts):
        if isinstance(part, int):
            out += f"[{part}]"
        elif k > 0 and isinstance(parts[k - 1], int) and part in STAGE_KINDS and parts[:1] == ["stages"]:
            continue
        elif k > 0 and isinstance(parts[k - 1], int) and _union_member(part):
            continue  # which member of a union pydantic tried: not a field the user wrote
        else:
            out += f".{part}" if out else str(part)
    if error_type in UNION_TAG_ERRORS and parts[:1] == ["stages"]:
        out += ".kind"
    return out


def to_problem(exc: BaseException) -> dict[str, Any]:
    """The RFC 9457 body for any exception: type, title, status, detail, then the error's own data."""
    status, slug, title = lookup(exc)
    extra: dict[str, Any] = {}
    if isinstance(exc, RequestValidationError):
        found = exc.errors()
        shown = found[:MAX_ERRORS]  # the first ones and how many in all: 1.3 million once made 86 MB
        locs = [list(e.get("loc", ())) for e in shown]
        msgs = [str(e.get("msg", "")) for e in shown]
        kinds = [str(e.get("type", "")) for e in shown]
        extra["error_count"] = len(found)
        if locs:
            extra["field"] = field_name(locs[0], kinds[0])
        where = ".".join(str(p) for p in locs[0]) if locs else ""
        msg = msgs[0] if msgs else "invalid request"
        detail = f"{where}: {msg}" if where else msg
        extra["errors"] = [{"loc": loc, "field": field_name(loc), "msg": m} for loc, m in zip(locs, msgs, strict=True)]
    elif isinstance(exc, StarletteHTTPException):
        detail = str(exc.detail)
    elif isinstance(exc, domain.CalibrationError | service.ServiceError):
        detail = exc.detail
        extra = {k: v for k, v in exc.data.items() if k not in RESERVED}
    else:
        detail = "an unexpected error occurred; it has been logged"
    return {"type": TYPE_BASE + slug, "title": title, "status": status, "detail": detail, **extra}


def response(body: dict[str, Any]) -> JSONResponse:
    status = int(body["status"])
    headers = {"WWW-Authenticate": "ApiKey"} if status == 401 else None
    if "retry_after" in body:
        headers = {"Retry-After": str(body["retry_after"])}
    return JSONResponse(body, status_code=status, media_type=PROBLEM_JSON, headers=headers)


def install(app: FastAPI) -> None:
    async def handle(request: Request, exc: Exception) -> JSONResponse:
        if lookup(exc) == INTERNAL:
            log.exception("unhandled error", exc_info=exc)
        return response(to_problem(exc))

    for cls in (
        domain.CalibrationError,
        service.ServiceError,
        RequestValidationError,
        StarletteHTTPException,
        Exception,
    ):
        app.add_exception_handler(cls, handle)
