from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, Query, Request, Response
from fastapi.responses import JSONResponse

from service import operations
from service.persistence import Database, Repository
from service.routes.csv_io import joints_csv
from service.routes.deps import compute, database, wants_csv
from service.schemas.common import JobAccepted
from service.schemas.designs import PoseDesignCreate, PoseDesignPublic

router = APIRouter(tags=["pose designs"])
_CSV = {200: {"content": {"text/csv": {"schema": {"type": "string"}}}}, 202: {"model": JobAccepted}}


def _answer(request: Request, record_public: dict[str, Any]) -> Any:
    if wants_csv(request):
        return Response(joints_csv(record_public["poses"]), media_type="text/csv")
    return record_public


@router.post(
    "/v1/robots/{robot_id}/pose-designs",
    status_code=201,
    response_model=PoseDesignPublic,
    responses=_CSV,  # type: ignore[arg-type]
)
async def create_design(
    robot_id: str,
    body: PoseDesignCreate,
    request: Request,
    run_async: bool = Query(False, alias="async", description="Run as a job: 202 with a job id"),
    db: Database = Depends(database),
) -> Any:
    if run_async:
        with db.session() as s:
            repo = Repository(s)
            repo.robot(robot_id)
            job = repo.add_job("pose_design", robot_id, body.model_dump(mode="json"))
        request.app.state.jobs.submit(job.id)
        return JSONResponse({"job_id": job.id, "status_url": f"/v1/jobs/{job.id}"}, status_code=202)
    record = await compute(request, "pose_design", lambda: operations.design(db, robot_id, body))
    return _answer(request, operations.design_public(record))


@router.get("/v1/pose-designs/{design_id}", response_model=PoseDesignPublic, responses=_CSV)  # type: ignore[arg-type]
def get_design(design_id: str, request: Request, db: Database = Depends(database)) -> Any:
    with db.reader() as s:
        return _answer(request, operations.design_public(Repository(s).design(design_id)))
