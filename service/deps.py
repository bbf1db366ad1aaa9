"""FastAPI dependencies, as Annotated aliases: what a route needs from the application, injected.

The dependencies are `async def` on purpose: a plain `def` dependency costs a thread-pool hop on every request.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Annotated, TypeVar

from fastapi import Depends, Request

from service import limits, security
from service.jobs import JobRunner
from service.metrics import Metrics
from service.model_cache import ModelCache
from service.persistence import Database

T = TypeVar("T")


async def database(request: Request) -> Database:
    db: Database = request.app.state.db
    return db


async def metrics(request: Request) -> Metrics:
    m: Metrics = request.app.state.metrics
    return m


async def model_cache(request: Request) -> ModelCache:
    cache: ModelCache = request.app.state.models
    return cache


async def jobs(request: Request) -> JobRunner:
    runner: JobRunner = request.app.state.jobs
    return runner


async def require_api_key(request: Request) -> None:
    """On the /v1 routers: with keys configured, a key whose scope covers the route (service.security), and
    `request.state.actor` set to the key's name."""
    route = request.scope.get("route")
    security.authorize(request, security.required_scope(request.method, getattr(route, "path", "")))


DatabaseDep = Annotated[Database, Depends(database)]
MetricsDep = Annotated[Metrics, Depends(metrics)]
ModelCacheDep = Annotated[ModelCache, Depends(model_cache)]
JobsDep = Annotated[JobRunner, Depends(jobs)]
ApiKeyDep = Depends(require_api_key)


async def compute(m: Metrics, kind: str, fn: Callable[[], T]) -> T:
    """Run CPU work off the event loop, within the compute slots (service.limits), and time it."""
    started = time.perf_counter()
    try:
        return await limits.run_gated(fn)
    finally:
        m.solve.labels(kind).observe(time.perf_counter() - started)


def wants_csv(request: Request) -> bool:
    accept = request.headers.get("accept", "")
    return "text/csv" in accept and "application/json" not in accept
