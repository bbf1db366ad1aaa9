from __future__ import annotations

from fastapi import APIRouter, Query, Response

from service.http.deps import DatabaseDep, Limit, Offset
from service.http.json_bodies import OffloopRoute
from service.http.operations import operation
from service.http.responses import model_json, models_json
from service.http.security import Scope
from service.schemas.jobs import JobKind, JobPublic, JobStatus
from service.services import jobs

router = APIRouter(tags=["jobs"], route_class=OffloopRoute)


@router.get("/v1/jobs", response_model=list[JobPublic])
@operation(Scope.read)
def list_jobs(
    db: DatabaseDep,
    *,
    status: JobStatus | None = Query(None),
    kind: JobKind | None = Query(None),
    robot_id: str | None = Query(None, max_length=36),
    limit: Limit = 100,
    offset: Offset = 0,
) -> Response:
    """Newest first; results are left out (`result: null`): GET the job for its result."""
    found = jobs.list_jobs(db=db, status=status, kind=kind, robot_id=robot_id, limit=limit, offset=offset)
    return models_json(found, JobPublic)


@router.get("/v1/jobs/{job_id}", response_model=JobPublic)
@operation(Scope.read)
def get_job(job_id: str, db: DatabaseDep) -> Response:
    return model_json(jobs.get_job(db=db, job_id=job_id))


@router.delete(
    "/v1/jobs/{job_id}",
    response_model=JobPublic,
    responses={409: {"description": "The job has already ended"}},
)
@operation(Scope.write)  # cancels what a write key submitted; deletes no record
def cancel_job(job_id: str, db: DatabaseDep) -> Response:
    """A queued job is cancelled at once; a running one stops at its next progress point (the answer then
    says `cancel_requested`), and nothing of it is written."""
    return model_json(jobs.cancel_job(db=db, job_id=job_id))
