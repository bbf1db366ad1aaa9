from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

import anyio
from fastapi import Request

from service.metrics import Metrics
from service.persistence import Database

T = TypeVar("T")


async def database(request: Request) -> Database:
    # async on purpose: a plain `def` dependency costs a thread-pool hop on every request.
    db: Database = request.app.state.db
    return db


def metrics(request: Request) -> Metrics:
    m: Metrics = request.app.state.metrics
    return m


async def compute(request: Request, kind: str, fn: Callable[[], T]) -> T:
    """Run CPU work off the event loop and time it."""
    started = time.perf_counter()
    try:
        return await anyio.to_thread.run_sync(fn)
    finally:
        metrics(request).solve.labels(kind).observe(time.perf_counter() - started)


def wants_csv(request: Request) -> bool:
    accept = request.headers.get("accept", "")
    return "text/csv" in accept and "application/json" not in accept
