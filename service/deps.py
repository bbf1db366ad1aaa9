"""FastAPI dependencies, as Annotated aliases: what a route needs from the application, injected.

The dependencies are `async def` on purpose: a plain `def` dependency costs a thread-pool hop on every request.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from typing import Annotated, TypeVar

import anyio
from fastapi import Depends, Request

from service.errors import Unauthorized
from service.jobs import Requeuing
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


async def jobs(request: Request) -> Requeuing:
    runner: Requeuing = request.app.state.jobs
    return runner


async def require_api_key(request: Request) -> None:
    """On the /v1 router: with keys configured, every call there needs one of them in X-API-Key."""
    keys: frozenset[str] = request.app.state.settings.keys
    if not keys:
        return
    given = request.headers.get("x-api-key", "").encode("latin-1")
    # compare_digest on every key: the time taken does not tell which prefix of which key matched.
    if not any(secrets.compare_digest(given, key.encode()) for key in keys):
        raise Unauthorized("send a valid API key in the X-API-Key header")


DatabaseDep = Annotated[Database, Depends(database)]
MetricsDep = Annotated[Metrics, Depends(metrics)]
ModelCacheDep = Annotated[ModelCache, Depends(model_cache)]
JobsDep = Annotated[Requeuing, Depends(jobs)]
ApiKeyDep = Depends(require_api_key)


async def compute(m: Metrics, kind: str, fn: Callable[[], T]) -> T:
    """Run CPU work off the event loop and time it."""
    started = time.perf_counter()
    try:
        return await anyio.to_thread.run_sync(fn)
    finally:
        m.solve.labels(kind).observe(time.perf_counter() - started)


def wants_csv(request: Request) -> bool:
    accept = request.headers.get("accept", "")
    return "text/csv" in accept and "application/json" not in accept
