from __future__ import annotations

from fastapi import APIRouter, Depends, Request, Response
from prometheus_client import CONTENT_TYPE_LATEST, generate_latest

from service.errors import NotReady
from service.persistence import Database, Repository
from service.routes.deps import database, metrics

router = APIRouter(tags=["health"])


@router.get("/healthz")
def healthz() -> dict[str, str]:
    return {"status": "ok"}


@router.get("/readyz", responses={503: {"description": "The database does not answer"}})
def readyz(db: Database = Depends(database)) -> Response:
    if db.ping():
        return Response('{"status":"ready"}', media_type="application/json")
    raise NotReady("the database does not answer")


@router.get("/metrics", include_in_schema=False)
def prometheus(request: Request, db: Database = Depends(database)) -> Response:
    m = metrics(request)
    try:
        with db.reader() as s:
            repo = Repository(s)
            for status in ("queued", "running"):
                m.queue.labels(status).set(repo.count_jobs(status))
    except Exception:  # metrics still answer when the database does not
        pass
    return Response(generate_latest(m.registry), media_type=CONTENT_TYPE_LATEST)
