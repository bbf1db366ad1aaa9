"""The FastAPI application: middleware (request id, logs, metrics, API key, body limit), routes, start-up."""

from __future__ import annotations

import logging
import secrets
import time
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from typing import Any

import anyio
from fastapi import FastAPI, Request, Response
from fastapi.openapi.utils import get_openapi
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service import logs, problems, warmup
from service.jobs import JobRunner
from service.metrics import Metrics
from service.persistence import Database
from service.routes import calibrations, designs, error_analysis, health, jobs, kinematics, robots
from service.schemas.calibrations import CalibrationCreate
from service.schemas.common import JobAccepted
from service.settings import Settings, get_settings

log = logging.getLogger("service.http")
PROBLEM_SCHEMA: dict[str, Any] = {
    "title": "Problem",
    "description": "RFC 9457 problem document; more members may carry data about the error",
    "type": "object",
    "required": ["type", "title", "status", "detail"],
    "properties": {
        "type": {"type": "string"},
        "title": {"type": "string"},
        "status": {"type": "integer"},
        "detail": {"type": "string"},
        "errors": {
            "type": "array",
            "items": {"type": "object", "properties": {"loc": {"type": "array"}, "msg": {"type": "string"}}},
        },
    },
    "additionalProperties": True,
}
PROBLEM_RESPONSES = {
    "400": "Malformed request (e.g. a CSV body that does not follow the header)",
    "401": "Missing or wrong API key (when keys are configured)",
    "404": "Unknown id",
    "413": "Request body too large",
    "415": "Unsupported media type",
    "422": "Invalid input: what is wrong and where",
    "503": "Not ready",
}


class BodyLimit:
    """413 for bodies over the limit, by Content-Length or by counting a streamed body."""

    def __init__(self, app: ASGIApp, limit: int) -> None:
        self.app, self.limit = app, limit

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = dict(scope.get("headers", [])).get(b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.limit:
            await self._reject(scope, receive, send)
            return
        seen = 0

        async def counted() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.limit:
                    raise problems.PayloadTooLarge(f"the request body exceeds {self.limit} bytes")
            return message

        await self.app(scope, counted, send)

    async def _reject(self, scope: Scope, receive: Receive, send: Send) -> None:
        response = problems.problem(
            413,
            "payload-too-large",
            "Request body too large",
            f"the request body exceeds {self.limit} bytes; send less",
        )
        await response(scope, receive, send)


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or get_settings()
    logs.configure(settings.log_level)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        db = Database(settings.database_url)
        await anyio.to_thread.run_sync(db.migrate)
        if settings.warm_up:
            await anyio.to_thread.run_sync(warmup.warm_up)
        runner = JobRunner(db, settings.job_workers)
        app.state.db, app.state.jobs = db, runner
        interrupted, resubmitted = runner.recover()
        log.info("ready", extra={"path": settings.database_url.split("@")[-1]})
        if interrupted or resubmitted:
            log.warning("jobs after restart: %d interrupted, %d resubmitted", interrupted, resubmitted)
        try:
            yield
        finally:
            runner.shutdown()
            db.dispose()

    app = FastAPI(
        title="IWR calibration service",
        version="1.0.0",
        description="Calibration of the Intersector Welding Robot: models, pose design, identification, "
        "compensation. Millimetres and degrees; orientations as unit quaternions [w, x, y, z].",
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.state.metrics = Metrics()
    problems.install(app)
    for module in (robots, kinematics, designs, calibrations, jobs, error_analysis, health):
        app.include_router(module.router)
    keys = settings.keys

    @app.middleware("http")
    async def observe(request: Request, call_next: Callable[[Request], Awaitable[Response]]) -> Response:
        rid = request.headers.get("x-request-id") or uuid.uuid4().hex
        token = logs.request_id.set(rid)
        started = time.perf_counter()
        try:
            if keys and request.url.path.startswith("/v1") and not _authorised(request, keys):
                response: Response = problems.from_exception(
                    problems.Unauthorized("send a valid API key in the X-API-Key header")
                )
            else:
                try:
                    response = await call_next(request)
                except problems.PayloadTooLarge as exc:
                    response = problems.from_exception(exc)
            elapsed = time.perf_counter() - started
            route = request.scope.get("route")
            template = getattr(route, "path", "unmatched")
            metrics: Metrics = app.state.metrics
            metrics.requests.labels(request.method, template, str(response.status_code)).inc()
            metrics.latency.labels(request.method, template).observe(elapsed)
            response.headers["X-Request-ID"] = rid
            log.info(
                "request",
                extra={
                    "method": request.method,
                    "path": request.url.path,
                    "status": response.status_code,
                    "duration_ms": round(1e3 * elapsed, 3),
                },
            )
            return response
        finally:
            logs.request_id.reset(token)

    app.add_middleware(BodyLimit, limit=settings.max_body_bytes)

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
            components = schema.setdefault("components", {}).setdefault("schemas", {})
            for model in (CalibrationCreate, JobAccepted):
                extra = model.model_json_schema(ref_template="#/components/schemas/{model}")
                for name, sub in extra.pop("$defs", {}).items():
                    components.setdefault(name, sub)
                components[model.__name__] = extra
            components["Problem"] = PROBLEM_SCHEMA
            components.pop("HTTPValidationError", None)
            components.pop("ValidationError", None)
            for path, operations in schema.get("paths", {}).items():
                for operation in operations.values():
                    responses = operation.setdefault("responses", {})
                    for status, description in PROBLEM_RESPONSES.items():
                        if status == "404" and "{" not in path:
                            continue
                        responses[status] = {
                            "description": description,
                            "content": {problems.PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}},
                        }
            if keys:
                schema["components"]["securitySchemes"] = {
                    "ApiKey": {"type": "apiKey", "in": "header", "name": "X-API-Key"}
                }
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
    return app


def _authorised(request: Request, keys: frozenset[str]) -> bool:
    given = request.headers.get("x-api-key", "")
    return any(secrets.compare_digest(given, key) for key in keys)
