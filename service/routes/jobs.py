from __future__ import annotations

from fastapi import APIRouter, Response

from service.deps import DatabaseDep
from service.responses import model_json
from service.schemas.jobs import JobPublic
from service.services import jobs

router = APIRouter(tags=["jobs"])


@router.get("/v1/jobs/{job_id}", response_model=JobPublic)
def get_job(job_id: str, db: DatabaseDep) -> Response:
    return model_json(jobs.get_job(db=db, job_id=job_id))
