"""Long work as jobs: `submit_job` for every kind, the same use-case functions to run them, and the job's view."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from pydantic import BaseModel

from models import Registry
from service.compute.model_cache import ModelCache
from service.conversions.calibrations import calibration_public
from service.conversions.designs import design_public
from service.conversions.jobs import accepted_out, job_out
from service.errors import JobFinished, NotFound, NotReady, QueueFull
from service.http.problems import to_problem
from service.persistence import Database, Repository
from service.persistence.job_store import JobStore
from service.persistence.lifecycle import Actor, check_revision
from service.persistence.repository import new_id
from service.persistence.tables import Job
from service.schemas.calibrations import CalibrationCreate, CalibrationPublic
from service.schemas.designs import PoseDesignCreate, PoseDesignPublic
from service.schemas.jobs import JobAccepted, JobKind, JobPublic, JobStatus
from service.schemas.programs import ProgramRequest, ProgramResponse
from service.services import calibrations, designs, programs
from service.services.hooks import JobHooks


class Submitter(Protocol):
    """What hands a queued job to a worker: the embedded `JobRunner` or the Celery publisher."""

    queue_limit: int
    retry_after: int

    def submit(self, job_id: str, kind: str = "") -> None: ...


def submit_job(
    *,
    db: Database,
    jobs: Submitter,
    kind: JobKind,
    robot_id: str,
    body: BaseModel,
    actor: Actor | None = None,
    if_match: str | None = None,
    extra: dict[str, Any] | None = None,
) -> JobAccepted:
    """Store the validated request as a queued job of an existing robot and hand it to the engine; 429 when
    the engine's `queue_limit` jobs are already waiting. `actor` (who submitted it) goes with the job, so what the
    job changes is audited under the submitter's key name and request id. `if_match` (the robot's ETag) is
    checked now, and what the job starts from is fixed now (`_pinned`): a worker that starts it later works on
    what the client saw when it submitted. `extra`: stored with the request, for its use case (`ENCODING`)."""
    job_id, queue_limit = new_id(), jobs.queue_limit
    with db.session() as s:
        robot = Repository(s).robot(robot_id)
        check_revision(robot, if_match)
        body = _pinned(body, robot.current_version)
        store = JobStore(s)
        waiting = store.count("queued")
        if waiting >= queue_limit:
            raise QueueFull(
                f"{waiting} jobs are waiting, the queue's bound is {queue_limit}; retry later",
                limit=queue_limit,
                retry_after=jobs.retry_after,
            )
        request = body.model_dump(mode="json") | (extra or {})
        if actor is not None:
            request[SUBMITTED_BY] = {"name": actor.name, "request_id": actor.request_id}
        job = store.add(job_id, kind, robot_id, request)
    try:
        jobs.submit(job_id, kind)
    except Exception as exc:  # the broker does not answer: the job must not wait for a message never sent
        unreachable = NotReady(f"the job queue does not answer ({type(exc).__name__}); submit again later")
        with db.session() as s:
            JobStore(s).fail_unsent(job_id, to_problem(unreachable))
        raise unreachable from exc
    return accepted_out(job)


def _pinned(body: BaseModel, current_version: int) -> BaseModel:
    """A calibration without `start_version` starts from the version current at submission, not at whatever is
    current when a worker picks it up: a job submitted at version 4 was applied as version 6 over a synchronous
    version 5 (issue 31). Pinned, it is stored and not applied when another version became current meanwhile,
    as a synchronous calibration is (its result names the conflict)."""
    if isinstance(body, CalibrationCreate) and body.start_version is None:
        return body.model_copy(update={"start_version": current_version})
    return body


SUBMITTED_BY = "_submitted_by"
"""The key of the stored request that names who submitted the job (not part of the request's schema)."""


def _submitter(request: dict[str, Any]) -> tuple[dict[str, Any], Actor | None]:
    body = dict(request)
    who = body.pop(SUBMITTED_BY, None)
    return body, None if who is None else Actor(name=who.get("name"), request_id=who.get("request_id"))


@dataclass(frozen=True)
class _Run:
    """One delivery of a job to its use case: what the worker owns, and the stored request."""

    db: Database
    models: ModelCache
    registry: Registry
    robot_id: str
    request: dict[str, Any]
    job: JobHooks | None


def _calibration(run: _Run) -> str:
    fields, actor = _submitter(run.request)
    body = CalibrationCreate.model_validate(fields)
    found = calibrations.calibrate(
        db=run.db, registry=run.registry, robot_id=run.robot_id, body=body, actor=actor, job=run.job
    )
    return found.id


def _design(run: _Run) -> str:
    body = PoseDesignCreate.model_validate(_submitter(run.request)[0])
    found = designs.create_design(
        db=run.db, models=run.models, registry=run.registry, robot_id=run.robot_id, body=body, job=run.job
    )
    return found.id


ENCODING = "_encoding"
"""The key of a program compensation's stored request that names the encoding a program sent as text was read in
(not part of the request's schema: the answer gives it back)."""


def _program(run: _Run) -> str:
    fields = _submitter(run.request)[0]
    encoding = fields.pop(ENCODING, None)
    body = ProgramRequest.model_validate(fields)
    return programs.compensate_as_job(
        db=run.db,
        models=run.models,
        registry=run.registry,
        robot_id=run.robot_id,
        body=body,
        encoding=encoding,
        job=run.job,
    )


JobResult = CalibrationPublic | PoseDesignPublic | ProgramResponse


@dataclass(frozen=True)
class JobType:
    """A job kind: the use case that runs it (returning the id of what it created) and that result's public form."""

    run: Callable[[_Run], str]
    result: Callable[[Repository, str], JobResult]


JOB_TYPES: dict[str, JobType] = {
    "calibration": JobType(_calibration, lambda repo, rid: calibration_public(repo.calibration(rid))),
    "pose_design": JobType(_design, lambda repo, rid: design_public(repo.design(rid))),
    "program_compensation": JobType(
        _program, lambda repo, rid: ProgramResponse.model_validate(repo.compensated_program(rid).result)
    ),
}
"""Every job kind by its name (`JobKind`, an operation's `job=`): tests/service/test_jobs.py checks that the three
agree, so a new kind is its operation's declaration, its schema name and its entry here."""


def run_job(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    kind: str,
    robot_id: str,
    request: dict[str, Any],
    job: JobHooks | None = None,
) -> str:
    if kind not in JOB_TYPES:
        raise ValueError(f"no such job kind {kind!r}")
    return JOB_TYPES[kind].run(_Run(db, models, registry, robot_id, request, job))


def _public(repo: Repository, job: Job, *, with_result: bool = True) -> JobPublic:
    result: JobResult | None = None
    if with_result and job.status == "succeeded" and job.result_id:
        result = JOB_TYPES[job.kind].result(repo, job.result_id)
    return job_out(job, result)


def get_job(*, db: Database, job_id: str) -> JobPublic:
    with db.reader() as s:
        return _public(Repository(s), Repository(s).job(job_id))


def list_jobs(
    *,
    db: Database,
    status: JobStatus | None,
    kind: JobKind | None,
    robot_id: str | None,
    limit: int,
    offset: int,
) -> list[JobPublic]:
    """Newest first, without results (a page of 100 designs would be megabytes): GET one job for its result."""
    with db.reader() as s:
        repo = Repository(s)
        rows = JobStore(s).page(status=status, kind=kind, robot_id=robot_id, limit=limit, offset=offset)
        return [_public(repo, job, with_result=False) for job in rows]


def cancel_job(*, db: Database, job_id: str) -> JobPublic:
    """A queued job is cancelled now; a running one stops at its next progress point, writing nothing."""
    with db.session() as s:
        store = JobStore(s)
        if store.get(job_id) is None:
            raise NotFound(f"no job with id {job_id!r}", resource="job", id=job_id)
        if not store.request_cancel(job_id):
            found = store.get(job_id)
            status = found.status if found is not None else "unknown"
            raise JobFinished(f"job {job_id} has already ended ({status}); nothing to cancel", job_status=status)
    return get_job(db=db, job_id=job_id)


def queue_depth(*, db: Database) -> dict[str, int]:
    """Jobs waiting and running, for the metrics."""
    with db.reader() as s:
        store = JobStore(s)
        return {status: store.count(status) for status in ("queued", "running")}


def job_durations(*, db: Database) -> list[tuple[str, int, float]]:
    with db.reader() as s:
        return JobStore(s).durations()
