from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends

from service import operations
from service.persistence import Database, Repository
from service.routes.deps import database
from service.schemas.common import Public

router = APIRouter(tags=["jobs"])


class JobPublic(Public):
    id: str
    kind: str
    status: str
    result: dict[str, Any] | None = None
    error: dict[str, Any] | None = None


@router.get("/v1/jobs/{job_id}", response_model=JobPublic)
def get_job(job_id: str, db: Database = Depends(database)) -> dict[str, Any]:
    with db.reader() as s:
        repo = Repository(s)
        job = repo.job(job_id)
        result = None
        if job.status == "succeeded" and job.result_id:
            if job.kind == "calibration":
                result = operations.calibration_public(repo.calibration(job.result_id))
            else:
                result = operations.design_public(repo.design(job.result_id))
        return {
            "id": job.id,
            "kind": job.kind,
            "status": job.status,
            "result": result,
            "error": job.error,
            "created_at": job.created_at,
            "started_at": job.started_at,
            "finished_at": job.finished_at,
        }
