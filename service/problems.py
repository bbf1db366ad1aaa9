"""RFC 9457 problem documents: one table from domain errors to HTTP, and the handlers that use it.

Routes never build HTTP errors by hand: they raise domain errors (`models.errors`) or the few service
errors below, and this module turns every one into `application/problem+json`.
"""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from models import errors as domain

PROBLEM_JSON = "application/problem+json"
TYPE_BASE = "https://iwr-calibration.example/problems/"
log = logging.getLogger("service.problems")


class ServiceError(Exception):
    """Errors of the service layer itself (not of the mathematics)."""

    def __init__(self, detail: str, **data: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.data = data


class NotFound(ServiceError):
    pass


class Unauthorized(ServiceError):
    pass


class PayloadTooLarge(ServiceError):
    pass


class UnsupportedMediaType(ServiceError):
    pass


class BadRequest(ServiceError):
    pass


PROBLEMS: dict[type[Exception], tuple[int, str, str]] = {
    # domain errors: the caller's data
    domain.WrongShape: (422, "wrong-shape", "Wrong shape"),
    domain.NonFiniteValue: (422, "non-finite-value", "Not a finite number"),
    domain.JointOutOfRange: (422, "joint-out-of-range", "Joint outside its range"),
    domain.UnreachablePose: (422, "unreachable-pose", "Pose the robot cannot reach"),
    domain.InvalidQuaternion: (422, "invalid-quaternion", "Not a unit quaternion"),
    domain.TooFewMeasurements: (422, "too-few-measurements", "Too few measurements"),
    domain.UnknownParameter: (422, "unknown-parameter", "Unknown parameter or group"),
    domain.InvalidInput: (422, "invalid-input", "Invalid input"),
    domain.NotIdentifiable: (422, "not-identifiable", "Nothing identifiable"),
    domain.InconsistentData: (422, "inconsistent-data", "Data inconsistent with the robot"),
    domain.SolverFailed: (422, "solver-failed", "The solver did not converge"),
    domain.CalibrationError: (422, "calibration-error", "Calibration error"),
    # the service's own
    NotFound: (404, "not-found", "Not found"),
    Unauthorized: (401, "unauthorized", "API key missing or wrong"),
    PayloadTooLarge: (413, "payload-too-large", "Request body too large"),
    UnsupportedMediaType: (415, "unsupported-media-type", "Unsupported media type"),
    BadRequest: (400, "bad-request", "Bad request"),
}


def lookup(exc: Exception) -> tuple[int, str, str]:
    for cls in type(exc).__mro__:
        if cls in PROBLEMS:
            return PROBLEMS[cls]
    return 500, "internal-error", "Internal error"


def problem(status: int, slug: str, title: str, detail: str, **extra: Any) -> JSONResponse:
    body = {"type": TYPE_BASE + slug, "title": title, "status": status, "detail": detail, **extra}
    headers = {"WWW-Authenticate": "ApiKey"} if status == 401 else None
    return JSONResponse(body, status_code=status, media_type=PROBLEM_JSON, headers=headers)


def from_exception(exc: domain.CalibrationError | ServiceError) -> JSONResponse:
    status, slug, title = lookup(exc)
    data = {k: v for k, v in exc.data.items() if k not in {"type", "title", "status", "detail"}}
    return problem(status, slug, title, exc.detail, **data)


def install(app: FastAPI) -> None:
    @app.exception_handler(domain.CalibrationError)
    async def _domain(request: Request, exc: domain.CalibrationError) -> JSONResponse:
        return from_exception(exc)

    @app.exception_handler(ServiceError)
    async def _service(request: Request, exc: ServiceError) -> JSONResponse:
        return from_exception(exc)

    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = [{"loc": list(e.get("loc", ())), "msg": str(e.get("msg", ""))} for e in exc.errors()]
        loc: list[object] = list(errors[0]["loc"]) if errors else []
        msg = str(errors[0]["msg"]) if errors else "invalid request"
        where = ".".join(str(p) for p in loc)
        return problem(422, "validation-error", "Invalid request", f"{where}: {msg}" if where else msg, errors=errors)

    @app.exception_handler(StarletteHTTPException)
    async def _http(request: Request, exc: StarletteHTTPException) -> JSONResponse:
        titles = {404: "Not found", 405: "Method not allowed", 406: "Not acceptable", 415: "Unsupported media type"}
        return problem(
            exc.status_code, f"http-{exc.status_code}", titles.get(exc.status_code, "HTTP error"), str(exc.detail)
        )

    @app.exception_handler(Exception)
    async def _unexpected(request: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error")
        return problem(500, "internal-error", "Internal error", "an unexpected error occurred; it has been logged")
