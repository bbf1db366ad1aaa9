"""FastAPI dependencies, as Annotated aliases: what a route needs from the application, injected.

The dependencies are `async def` on purpose: a plain `def` dependency costs a thread-pool hop on every request.
"""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from dataclasses import dataclass
from typing import Annotated, Any, TypeVar

from fastapi import Depends, Query, Request

from models import Registry
from service import logs
from service.compute import limits
from service.compute.builds import StructureBuilds
from service.compute.model_cache import ModelCache
from service.compute.pool import Task
from service.errors import NotAcceptable
from service.http import operations, security
from service.jobs import Requeuing
from service.metrics import Metrics
from service.persistence import Database
from service.persistence.lifecycle import Actor
from service.settings import Settings

T = TypeVar("T")
INJECTED = {"db", "models", "registry"}
"""The arguments of a computation that each compute process supplies itself (service.compute.pool)."""


def _state(attribute: str, kind: type[T]) -> Callable[[Request], Awaitable[T]]:
    """The dependency that reads what the application's lifespan left on `app.state` as `attribute`."""

    async def dependency(request: Request) -> T:
        value = getattr(request.app.state, attribute)
        if not isinstance(value, kind):  # a lifespan that left something else is a bug, not a bad request
            raise TypeError(f"app.state.{attribute} is a {type(value).__name__}, not a {kind.__name__}")
        return value

    dependency.__name__ = attribute
    return dependency


async def require_api_key(request: Request) -> None:
    """On the /v1 routers: with keys configured, a key whose scope covers the route (service.http.security), and
    `request.state.actor` set to the key's name."""
    as_job = request.query_params.get("async", "").lower() in ("true", "1", "yes", "on")
    security.authorize(request, operations.required_scope(request.scope.get("route"), as_job=as_job))


async def actor(request: Request) -> Actor:
    """Who makes a change, for the audit trail: the API key's name that the key check leaves in
    `request.state.actor` (None without keys: never the key itself), and this request's id."""
    name = getattr(request.state, "actor", None)
    return Actor(name=None if name is None else str(name)[:100], request_id=logs.request_id.get())


DatabaseDep = Annotated[Database, Depends(_state("db", Database))]
MetricsDep = Annotated[Metrics, Depends(_state("metrics", Metrics))]
ModelCacheDep = Annotated[ModelCache, Depends(_state("models", ModelCache))]
RegistryDep = Annotated[Registry, Depends(_state("registry", Registry))]
"""The application's robot runtimes (made by its lifespan: `service.compute.registry.build_registry`)."""
BuildsDep = Annotated[StructureBuilds, Depends(_state("builds", StructureBuilds))]
"""The background builds of new structures (service.compute.builds)."""
JobsDep = Annotated[Requeuing, Depends(_state("jobs", Requeuing))]
SettingsDep = Annotated[Settings, Depends(_state("settings", Settings))]
"""The application's settings (`sync_budget_seconds` for `service.compute.limits.admit`)."""
ApiKeyDep = Depends(require_api_key)
Limit = Annotated[int, Query(ge=1, le=1000)]
"""A page's size (`?limit=`, default 100 where the route says so)."""
Offset = Annotated[int, Query(ge=0, le=1_000_000_000)]
"""How many items a page skips (`?offset=`): bounded, so the database never sees an integer it cannot hold."""
ActorDep = Annotated[Actor, Depends(actor)]


async def compute(m: Metrics, kind: str, fn: Callable[..., T], /, **kwargs: Any) -> T:
    """`fn(**kwargs)` in the compute pool, within the compute slots (service.compute.limits, service.compute.pool),
    timed.

    `fn` is a module-level function; its `db`, `models` and `registry` arguments are replaced by the compute
    process's own (a Database, a ModelCache or a Registry cannot travel to another process)."""
    inject = tuple(name for name, value in kwargs.items() if isinstance(value, Database | ModelCache | Registry))
    if not set(inject) <= INJECTED:  # the process supplies its own by these names only: a bug, not the client's
        raise TypeError(f"compute: pass the process's objects as {sorted(INJECTED)}, not {sorted(inject)}")
    task = Task(fn, {k: v for k, v in kwargs.items() if k not in inject}, inject)
    started = time.perf_counter()
    try:
        result: T = await limits.run_gated(task)
        return result
    finally:
        m.solve.labels(kind).observe(time.perf_counter() - started)


@dataclass(frozen=True)
class Compute:
    """The compute pool as a route uses it: each computation within the compute slots and timed into the metrics
    (`compute`), its estimated cost first admitted within the application's synchronous budget
    (`Settings.sync_budget_seconds`) where the route counts the work itself, once its body is read."""

    metrics: Metrics
    settings: Settings

    def admit(self, cost: limits.Estimate, *, run_async: bool, can_run_async: bool = True) -> None:
        """422 `work-too-large` for `cost` over the synchronous budget (unless it runs as a job) or over any job's
        cap (`limits.admit`); the refusal advises ?async=true where the operation has a job form."""
        budget_s = self.settings.sync_budget_seconds
        limits.admit(cost, run_async=run_async, can_run_async=can_run_async, budget_s=budget_s)

    async def __call__(self, kind: str, fn: Callable[..., T], /, **kwargs: Any) -> T:
        """`fn(**kwargs)` in the compute pool, timed as `kind` (`compute`)."""
        return await compute(self.metrics, kind, fn, **kwargs)

    async def admitted(self, cost: limits.Estimate, kind: str, fn: Callable[..., T], /, **kwargs: Any) -> T:
        """An operation with no job form: `cost` admitted (over the budget the client is told to send fewer at a
        time), then `fn(**kwargs)` in the compute pool."""
        self.admit(cost, run_async=False, can_run_async=False)
        return await self(kind, fn, **kwargs)


async def _compute(m: MetricsDep, settings: SettingsDep) -> Compute:
    return Compute(m, settings)


ComputeDep = Annotated[Compute, Depends(_compute)]
"""The compute pool with the application's metrics and budget (`Compute`)."""


def negotiate(request: Request, offered: list[str]) -> str:
    """The first of `offered` (the default) that the Accept header allows, by its q-values; 406 if none.

    `?format=` is read by the routes that offer it, before this. Parameters other than q are ignored, and
    `type/*` and `*/*` match as RFC 9110 says.
    """
    accept = request.headers.get("accept", "").strip()
    if not accept:
        return offered[0]
    ranges: list[tuple[str, float]] = []
    for part in accept.split(","):
        media, *params = (p.strip() for p in part.split(";"))
        q = 1.0
        for param in params:
            key, _, value = param.partition("=")
            if key.strip().lower() == "q":
                try:
                    q = float(value)
                except ValueError:
                    q = 0.0
        if media:
            ranges.append((media.lower(), q))

    def quality(media: str) -> float:
        kind = media.split("/", maxsplit=1)[0]
        # The most specific range that matches decides (text/csv;q=0 beats */*).
        for pattern in (media, f"{kind}/*", "*/*"):
            found = [q for m, q in ranges if m == pattern]
            if found:
                return max(found)
        return 0.0

    best = max(offered, key=lambda m: (quality(m), -offered.index(m)))
    if quality(best) <= 0:
        raise NotAcceptable(
            f"Accept {accept!r} allows none of {', '.join(offered)}; ask for one of them", offered=offered
        )
    return best


JSON_OR_CSV = {"json": "application/json", "csv": "text/csv"}
"""The `?format=` values of an answer offered as JSON (the default) or CSV, and their media types."""


def requested_media(request: Request, format: str | None, formats: dict[str, str]) -> str:
    """The media type that `?format=` names (a key of `formats`, validated by the route's query), else the first
    of `formats` that the Accept header allows (`negotiate`; 406 if none)."""
    return formats.get(format or "") or negotiate(request, list(formats.values()))


def wants_csv(request: Request) -> bool:
    accept = request.headers.get("accept", "")
    return "text/csv" in accept and "application/json" not in accept
