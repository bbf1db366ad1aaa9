"""The FastAPI application: middleware (request id, logs, metrics, body limit), routers, start-up."""

from __future__ import annotations

import base64
import hashlib
import importlib
import logging
import re
import time
import uuid
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
from fastapi import FastAPI
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from models import Registry
from service import logs, ui
from service.compute import limits
from service.compute.builds import StructureBuilds
from service.compute.model_cache import ModelCache
from service.compute.pool import ComputePool
from service.compute.registry import build_registry, native_functions
from service.errors import PayloadTooLarge
from service.http import openapi, problems, security
from service.http.deps import ApiKeyDep
from service.http.guards import BodyGuard, RequestGuard
from service.http.idempotency import Idempotency
from service.jobs import JobRunner, Requeuing, WorkerContext
from service.metrics import Metrics
from service.persistence import Database
from service.routes import (
    adaptive,
    audit,
    calibrations,
    campaigns,
    cells,
    checks,
    designs,
    error_analysis,
    fleets,
    health,
    jobs,
    kinematics,
    programs,
    reports,
    robot_trees,
    robots,
    validations,
    versions,
    vocabulary,
)
from service.settings import Settings, get_settings

log = logging.getLogger("service.http")


class HttpMiddleware:
    """An ASGI middleware of HTTP requests (`handle`); anything else (the lifespan) passes straight through."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        await self.handle(scope, receive, send)

    async def handle(self, scope: Scope, receive: Receive, send: Send) -> None:
        raise NotImplementedError


class BodyLimit(HttpMiddleware):
    """413 for bodies over the limit, by Content-Length or by counting a streamed body."""

    def __init__(self, app: ASGIApp, limit: int) -> None:
        super().__init__(app)
        self.limit = limit

    async def handle(self, scope: Scope, receive: Receive, send: Send) -> None:
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


class Observe(HttpMiddleware):
    """Request id, metrics and a structured log line per request (plain ASGI: no extra task per call)."""

    def __init__(self, app: ASGIApp, metrics: Metrics) -> None:
        super().__init__(app)
        self.metrics = metrics

    async def handle(self, scope: Scope, receive: Receive, send: Send) -> None:
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

        started_response = False

        async def send_tracked(message: Message) -> None:
            nonlocal started_response
            started_response = started_response or message["type"] == "http.response.start"
            await send_with_id(message)

        try:
            await self.app(scope, receive, send_tracked)
        except Exception as exc:
            # Here, not in Starlette's ServerErrorMiddleware: the request id is still set, so the log line
            # carries it; and the client gets a problem document instead of a reset connection.
            log.exception("unhandled error", exc_info=exc)
            if not started_response:
                await problems.response(problems.to_problem(exc))(scope, receive, send_with_id)
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


PAGE_POLICY = (
    "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
    "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'"
)
"""The Content-Security-Policy of the pages (/ui and everything not HTML): scripts only from the service's own
files, never inline (the UI has none: its views are modules, its events listeners), so an injected `<script>` or
`onerror=` does not run even if it reached the DOM. Inline styles stay allowed: the jobs view sets a progress
bar's width by attribute, and the report (shown in the UI's `srcdoc` iframe, which inherits this policy) carries
its own `<style>`; a style cannot run code. Nothing may frame the service (clickjacking)."""
DOCUMENT_POLICY = (
    "default-src 'none'; style-src 'unsafe-inline'; img-src data:; base-uri 'none'; form-action 'none'; "
    "frame-ancestors 'self'; sandbox"
)
"""The policy of any other HTML the API answers (a calibration's report): no script at all, its own inline
style and data images only, a sandbox (a unique origin: it cannot read the service's storage or call the API
with the user's credentials)."""
_INLINE_SCRIPT = re.compile(rb"<script>(.*?)</script>", re.DOTALL)


class SecurityHeaders(HttpMiddleware):
    """Content-Security-Policy, X-Frame-Options, nosniff and no referrer on every response. Swagger UI's page
    (/docs) starts itself with an inline script, which its policy allows by that script's hash (computed from
    the page as sent, so it holds whatever FastAPI writes) and nothing else inline."""

    async def handle(self, scope: Scope, receive: Receive, send: Send) -> None:
        docs = scope["path"] == "/docs"
        held: list[Message] = []

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                if docs:  # its policy depends on its body: sent with the body's first part
                    held.append(message)
                    return
                await send(_with_headers(message, _policy(scope["path"], message)))
                return
            if held:
                start = held.pop()
                hashes = [_sha256(script) for script in _INLINE_SCRIPT.findall(message.get("body", b""))]
                policy = PAGE_POLICY.replace("script-src 'self'", " ".join(["script-src 'self'", *hashes]))
                await send(_with_headers(start, policy))
            await send(message)

        await self.app(scope, receive, send_with_headers)


def _policy(path: str, start: Message) -> str:
    """The page's policy for the UI and for what is not HTML; the document's for other HTML (a report)."""
    content_type = dict(start.get("headers", [])).get(b"content-type", b"")
    return DOCUMENT_POLICY if content_type.startswith(b"text/html") and path != "/ui" else PAGE_POLICY


def _sha256(script: bytes) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(script).digest()).decode() + "'"


def _with_headers(start: Message, policy: str) -> Message:
    headers = [(k, v) for k, v in start.get("headers", []) if k.lower() != b"content-security-policy"]
    headers += [
        (b"content-security-policy", policy.encode()),
        (b"x-frame-options", b"DENY"),
        (b"x-content-type-options", b"nosniff"),
        (b"referrer-policy", b"no-referrer"),
    ]
    return {**start, "headers": headers}


def _dispose_earlier(app: FastAPI) -> None:
    earlier = getattr(app.state, "db", None)
    if isinstance(earlier, Database):
        earlier.dispose()


def make_runner(settings: Settings, db: Database, models: ModelCache, registry: Registry) -> Requeuing:
    """Celery when a broker is configured, else the embedded pool (nothing else to install or run)."""
    context = WorkerContext(
        db, models, registry, lease=settings.job_lease_seconds, max_attempts=settings.job_max_attempts
    )
    if settings.broker_url:
        from service.jobs.engine import CeleryRunner  # Celery loads only when configured

        return CeleryRunner(context, settings)
    # Each pool process builds its own registry from the settings (service.compute.registry), like the API.
    return JobRunner(context, settings)


def create_app(settings: Settings | None = None, *, registry: Registry | None = None) -> FastAPI:
    """The application; it builds its own robot runtimes at start-up (`service.compute.registry.build_registry`)
    unless given `registry` (tests share one across apps; whoever passes it has warmed it as they need)."""
    # Long on purpose: the application's wiring in one place (state, middleware, routes, start-up and shutdown),
    # in order.
    settings = settings or get_settings()
    logs.configure(settings.log_level)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        db = Database(settings.database_url)
        # An app started again (schemathesis runs the lifespan once per test on one app) may have been called
        # between two runs with the earlier run's Database, disposed then: its engine opened a fresh pool that
        # nobody would close, whose connections were garbage-collected open later, a ResourceWarning failing
        # whichever test ran then (issue 48). Closing that pool now leaves nothing to collect.
        _dispose_earlier(app)
        await anyio.to_thread.run_sync(db.migrate)
        # With compute processes, every computation runs in them (each warms its own registry): the API process
        # builds nothing ahead but the IWR's kinematics its metric reads, ~140 MB less resident (issue 30).
        own = settings if settings.compute_processes <= 0 else settings.model_copy(update={"warm_up": False})
        runtimes = registry if registry is not None else await anyio.to_thread.run_sync(build_registry, own)
        if settings.warm_up:
            app.state.metrics.native.set(1.0 if native_functions(runtimes) else 0.0)
            # The URDF reader's import (yourdfpy and trimesh: 2-5 s here) now, not in the first URDF request of
            # the process, which must answer (a hostile document too) within a second.
            await anyio.to_thread.run_sync(importlib.import_module, "yourdfpy")
        models = ModelCache(db)
        runner = make_runner(settings, db, models, runtimes)
        app.state.db, app.state.models, app.state.registry, app.state.jobs = db, models, runtimes, runner
        # Processes build their own registries from the settings; without processes the app's serves the threads.
        # Each computation may grow its process by the memory cap of any job at most (service.compute.pool's watchdog).
        compute = ComputePool(
            db, models, runtimes, settings, slots=limits.SYNC_COMPUTE_SLOTS, memory_bytes=limits.JOB_MEMORY_BYTES
        )
        await compute.start()
        app.state.compute = compute
        # New structures build in the background (service.compute.builds): in the app's registry when requests compute
        # in its threads, else in a process of their own that fills the disk cache the compute processes load.
        builds = StructureBuilds(
            runtimes, in_process=settings.compute_processes <= 0, enabled=settings.background_builds
        )
        app.state.builds = builds
        # No sweep of running jobs: those of a stopped process come back when their leases expire.
        resubmitted = runner.recover()
        log.info("ready", extra={"path": settings.database_url.split("@")[-1]})
        if resubmitted:
            log.warning("jobs after restart: %d queued jobs resubmitted", resubmitted)
        try:
            yield
        finally:
            builds.shutdown()
            compute.shutdown()
            runner.shutdown()
            db.dispose()

    app = FastAPI(
        title="IWR calibration service",
        version="1.0.0",
        description="Calibration of the Intersector Welding Robot: models, pose design, identification, "
        "compensation. Millimetres and degrees; orientations as unit quaternions [w, x, y, z].",
        lifespan=lifespan,
        docs_url=None,  # served by service.ui with local assets: the default loads Swagger UI from a CDN
        redoc_url=None,
        # No 307 to the path without its slash: its Location copied the client's Host header (service.http.guards
        # answers a 404 naming the path instead).
        redirect_slashes=False,
    )
    app.state.settings = settings
    app.state.api_keys = settings.keys  # parsed once: a wrong entry stops the start-up (service.http.security)
    app.state.metrics = Metrics()
    problems.install(app)
    ui.install(app)
    for module in (
        robots,
        versions,
        kinematics,
        designs,
        calibrations,
        campaigns,
        jobs,
        error_analysis,
        audit,
        validations,
        reports,
        programs,
        checks,
        fleets,
        cells,
        adaptive,
        robot_trees,
        vocabulary,
    ):
        app.include_router(module.router, dependencies=[ApiKeyDep])
    app.include_router(health.router)
    gate = limits.ComputeGate(
        limits.SYNC_COMPUTE_SLOTS, limits.SYNC_QUEUE, limits.QUEUE_WAIT_S, deadline_s=settings.compute_deadline_seconds
    )
    app.add_middleware(limits.Admission, gate=gate)
    app.add_middleware(Idempotency)  # inside BodyGuard: it reads the body BodyGuard replays
    app.add_middleware(BodyLimit, limit=settings.max_body_bytes)
    # Outside BodyLimit, which refuses a declared size over the limit before any read; BodyGuard reads every
    # other body once, on a deadline, and drains a chunked one over the limit before its 413.
    app.add_middleware(BodyGuard, limit=settings.max_body_bytes, timeout_s=settings.body_timeout_seconds)
    app.add_middleware(RequestGuard)
    app.add_middleware(security.GuardedPaths, metrics=not settings.metrics_public, docs=not settings.docs_public)
    app.add_middleware(SecurityHeaders)
    app.add_middleware(Observe, metrics=app.state.metrics)
    openapi.install(app)
    return app
