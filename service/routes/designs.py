from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Query, Request, Response

from optimal_design.problem import MAX_CANDIDATES
from service.compute import limits
from service.compute.model_cache import ModelCache
from service.files.csv_codec import joints_csv
from service.http.deps import ComputeDep, DatabaseDep, JobsDep, ModelCacheDep, RegistryDep, wants_csv
from service.http.json_bodies import OffloopRoute
from service.http.operations import POSE_DESIGN, Runs, operation
from service.http.responses import model_json
from service.http.security import Scope
from service.routes.pages import robot_list
from service.schemas.designs import PoseDesignCreate, PoseDesignPublic, PoseDesignSummaryPublic
from service.schemas.jobs import JobAccepted
from service.services import designs
from service.services.jobs import submit_job

router = APIRouter(tags=["pose designs"], route_class=OffloopRoute)
_CSV_BODY = {
    "content": {
        "text/csv": {"schema": {"type": "string", "description": "header: the robot's joint names (q1 … q_m, l1 … l6)"}}
    }
}
_CREATED: dict[int | str, dict[str, Any]] = {
    201: _CSV_BODY,
    202: {"model": JobAccepted, "description": "Accepted as a job (?async=true)"},
    429: {"description": "Job queue full"},
}
_FOUND: dict[int | str, dict[str, Any]] = {200: _CSV_BODY}


def _answer(request: Request, design: PoseDesignPublic, status_code: int, models: ModelCache) -> Response:
    """The stored report (validated where the service read it, see routes/calibrations.py), or its poses as CSV
    under the robot's joint header (robots.md: q1 … q_m, then l1 … l6)."""
    if wants_csv(request):
        names = models.current(design.robot_id)[0].joint_names
        return Response(joints_csv(design.poses, names), media_type="text/csv", status_code=status_code)
    return model_json(design, status_code=status_code)


@router.post("/v1/robots/{robot_id}/pose-designs", status_code=201, response_model=PoseDesignPublic, responses=_CREATED)
@operation(Scope.write, runs=Runs.COMPUTE, precount=POSE_DESIGN, job="pose_design")
async def create_design(
    robot_id: str,
    *,
    body: PoseDesignCreate,
    request: Request,
    db: DatabaseDep,
    models: ModelCacheDep,
    registry: RegistryDep,
    jobs: JobsDep,
    compute: ComputeDep,
    run_async: bool = Query(False, alias="async", description="Run as a job: 202 with a job id"),
) -> Response:
    candidates = body.offered()
    fixed = len(body.fixed) if body.fixed is not None else 0
    cost = (
        limits.target_design(candidates, fixed)
        if body.count is None
        else limits.pose_design(candidates, body.count, fixed, body.criterion.value, bound_seconds=body.bound_seconds)
    )
    if body.cell is not None:
        # Given candidates are each checked once; sampled ones until candidate_count are feasible.
        checked = candidates if body.candidates is not None else candidates * limits.CELL_SAMPLED_PER_CANDIDATE
        cost = limits.with_cell(cost, min(checked, MAX_CANDIDATES))
    compute.admit(cost, run_async=run_async)
    if run_async:
        accepted = submit_job(db=db, jobs=jobs, kind="pose_design", robot_id=robot_id, body=body)
        return model_json(accepted, status_code=202)
    design = await compute(
        "pose_design", designs.create_design, db=db, models=models, registry=registry, robot_id=robot_id, body=body
    )
    return _answer(request, design, 201, models)


@router.get("/v1/pose-designs/{design_id}", response_model=PoseDesignPublic, responses=_FOUND)
@operation(Scope.read)
def get_design(design_id: str, request: Request, db: DatabaseDep, models: ModelCacheDep) -> Response:
    return _answer(request, designs.get_design(db=db, design_id=design_id), 200, models)


robot_list(
    router,
    "/v1/robots/{robot_id}/pose-designs",
    PoseDesignSummaryPublic,
    designs.list_designs,
    name="list_designs",
    doc="""The robot's stored designs, oldest first (criterion, count, value); each one's poses by its id.""",
)
