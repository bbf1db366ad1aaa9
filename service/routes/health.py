from __future__ import annotations

from typing import Literal

from fastapi import APIRouter, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from service.errors import NotReady
from service.http.deps import DatabaseDep, MetricsDep
from service.schemas.common import Public
from service.services.jobs import job_durations, queue_depth

router = APIRouter(tags=["health"])


class StatusPublic(Public):
    status: Literal["ok", "ready"]


@router.get("/healthz", response_model=StatusPublic)
async def healthz() -> Response:
    # On the event loop: a plain `def` would hop to a worker thread and wait for the GIL behind whatever holds it,
    # which is what /healthz must not measure.
    return Response('{"status":"ok"}', media_type="application/json")


@router.get(
    "/readyz",
    response_model=StatusPublic,
    responses={503: {"description": "The database does not answer"}},
)
def readyz(db: DatabaseDep, request: Request) -> Response:
    # Every dependency a request or a job needs, each named when it fails: the database, and the job broker
    # when jobs run on Celery (the embedded engine has none).
    failing = [] if db.ping() else ["the database does not answer"]
    broker = request.app.state.jobs.unreachable()
    if broker is not None:
        failing.append(broker)
    if failing:
        raise NotReady("; ".join(failing))
    return Response('{"status":"ready"}', media_type="application/json")


@router.get("/metrics", include_in_schema=False)
def prometheus(db: DatabaseDep, m: MetricsDep) -> Response:
    try:
        depth = queue_depth(db=db)
        for status, count in depth.items():
            m.queue.labels(status).set(count)
        m.queue_depth.set(depth["queued"])
        m.running.set(depth["running"])
        for kind, count, seconds in job_durations(db=db):
            m.job_count.labels(kind).set(count)
            m.job_seconds.labels(kind).set(seconds)
    except Exception:  # metrics still answer when the database does not
        pass
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)
