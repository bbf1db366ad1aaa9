"""The FastAPI application: middleware (request id, logs, metrics, API key, body limit), routes, start-up."""

from __future__ import annotations

import logging
import secrets
import time
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from typing import Any

import anyio
from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from service import logs, problems, warmup
from service.errors import PayloadTooLarge, Unauthorized
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
                    raise PayloadTooLarge(f"the request body exceeds {self.limit} bytes", limit=self.limit)
            return message

        await self.app(scope, counted, send)

    async def _reject(self, scope: Scope, receive: Receive, send: Send) -> None:
        exc = PayloadTooLarge(f"the request body exceeds {self.limit} bytes; send less", limit=self.limit)
        await problems.response(problems.to_problem(exc))(scope, receive, send)


class Observe:
    """Request id, API key, metrics and a structured log line per request (plain ASGI: no extra task per call)."""

    def __init__(self, app: ASGIApp, metrics: Metrics, keys: frozenset[str]) -> None:
        self.app, self.metrics, self.keys = app, metrics, keys

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        headers = dict(scope.get("headers", []))
        rid = headers.get(b"x-request-id", b"").decode("latin-1")[:200] or uuid.uuid4().hex
        token = logs.request_id.set(rid)
        started = time.perf_counter()
        status = 500

        async def send_with_id(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = int(message["status"])
                message["headers"] = [*message.get("headers", []), (b"x-request-id", rid.encode("latin-1"))]
            await send(message)

        try:
            path = scope["path"]
            if self.keys and path.startswith("/v1") and not _authorised(headers.get(b"x-api-key", b""), self.keys):
                denied = problems.response(
                    problems.to_problem(Unauthorized("send a valid API key in the X-API-Key header"))
                )
                await denied(scope, receive, send_with_id)
            else:
                await self.app(scope, receive, send_with_id)
        finally:
            elapsed = time.perf_counter() - started
            template = getattr(scope.get("route"), "path", "unmatched")
            method = scope.get("method", "")
            self.metrics.requests.labels(method, template, str(status)).inc()
            self.metrics.latency.labels(method, template).observe(elapsed)
            if log.isEnabledFor(logging.INFO):
                log.info(
                    "request",
                    extra={
                        "method": method,
                        "path": scope["path"],
                        "status": status,
                        "duration_ms": round(1e3 * elapsed, 3),
                    },
                )
            logs.request_id.reset(token)


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

    app.add_middleware(BodyLimit, limit=settings.max_body_bytes)
    app.add_middleware(Observe, metrics=app.state.metrics, keys=keys)

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


def _authorised(given: bytes, keys: frozenset[str]) -> bool:
    return any(secrets.compare_digest(given, key.encode()) for key in keys)
