from __future__ import annotations

from typing import Any

from optimal_design import design_poses
from service.conversions.designs import design_public, report_out
from service.conversions.kinematics import joints_in
from service.model_cache import ModelCache
from service.persistence import Database, Repository
from service.schemas.designs import PoseDesignCreate
from service.services.hooks import JobHooks


def create_design(
    *, db: Database, models: ModelCache, robot_id: str, body: PoseDesignCreate, job: JobHooks | None = None
) -> dict[str, Any]:
    """The new design as `PoseDesignPublic` JSON, designed with the robot's current parameters (and stored with
    the job's own `succeeded` when run as one)."""
    if job is not None:
        job.progress("reading", 0.0)
    desc, theta = models.current(robot_id)
    candidates = joints_in(desc, body.candidates) if body.candidates is not None else None
    fixed = joints_in(desc, body.fixed) if body.fixed is not None else None
    if job is not None:
        job.progress("designing", 0.05)
    design = design_poses(
        desc,
        body.count,
        body.criterion,
        body.measurement,
        candidates=candidates,
        candidate_count=body.candidate_count,
        seed=body.seed,
        fixed=fixed,
        params=theta,
    )
    report = report_out(desc, design, candidates_given=candidates is not None).model_dump(mode="json")
    if job is not None:
        job.progress("storing", 0.95)
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)  # still there
        record = repo.add_design(robot_id, body.model_dump(mode="json"), report)
        if job is not None:
            job.commit(s, record.id)
        return design_public(record)


def get_design(*, db: Database, design_id: str) -> dict[str, Any]:
    with db.reader() as s:
        return design_public(Repository(s).design(design_id))
