"""A job is a database row (queued → running → succeeded | failed) and a task in a worker process pool.

Restart policy: at start-up, jobs left `running` by a stopped process are marked failed with reason
"interrupted" (their work may have been half done in a worker that died; the client resubmits), and jobs
still `queued` are submitted again, so no accepted job is lost.
"""

from __future__ import annotations

import logging
import multiprocessing
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from functools import lru_cache
from typing import Any

from service import operations
from service.errors import Interrupted
from service.persistence import Database, Repository
from service.problems import lookup, to_problem
from service.schemas.calibrations import CalibrationCreate
from service.schemas.designs import PoseDesignCreate

log = logging.getLogger("service.jobs")


@lru_cache(maxsize=4)
def _database(url: str) -> Database:
    return Database(url)


def execute_job(database_url: str, job_id: str, db: Database | None = None) -> str:
    """Run one job to completion in this process; returns its final status.

    Worker processes open one engine per database URL and keep it; in-process runs pass the app's own.
    """
    db = db or _database(database_url)
    with db.session() as s:
        repo = Repository(s)
        job = repo.job(job_id)
        if job.status != "queued":
            return job.status
        repo.start_job(job)
        kind, robot_id, request = job.kind, job.robot_id, job.request
    result_id: str | None = None
    error: dict[str, Any] | None = None
    try:
        if kind == "calibration":
            result_id = operations.calibrate(db, robot_id, CalibrationCreate.model_validate(request)).id
        elif kind == "pose_design":
            result_id = operations.design(db, robot_id, PoseDesignCreate.model_validate(request)).id
        else:
            raise ValueError(f"no such job kind {kind!r}")
    except Exception as exc:  # a job records every failure, as the synchronous request would have answered it
        if lookup(exc)[0] >= 500:
            log.exception("job %s failed", job_id)
        error = to_problem(exc)
    with db.session() as s:
        repo = Repository(s)
        job = repo.job(job_id)
        repo.finish_job(job, result_id=result_id, error=error)
        return job.status


class JobRunner:
    def __init__(self, db: Database, workers: int) -> None:
        self.db = db
        self.executor: Executor = (
            ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
            if workers > 0
            else ThreadPoolExecutor(max_workers=1)
        )
        self.futures: set[Future[str]] = set()

    def submit(self, job_id: str) -> None:
        if isinstance(self.executor, ThreadPoolExecutor):
            future = self.executor.submit(execute_job, self.db.url, job_id, self.db)
        else:
            future = self.executor.submit(execute_job, self.db.url, job_id)
        self.futures.add(future)
        future.add_done_callback(self._done)

    def _done(self, future: Future[str]) -> None:
        self.futures.discard(future)
        if future.exception() is not None:
            log.error("job worker crashed: %s", future.exception())

    def recover(self) -> tuple[int, int]:
        """(interrupted jobs marked failed, queued jobs resubmitted) after a restart."""
        with self.db.session() as s:
            repo = Repository(s)
            interrupted = repo.jobs_with_status("running")
            for job in interrupted:
                stopped = Interrupted("interrupted: the service stopped while this job ran; submit it again")
                repo.finish_job(job, error=to_problem(stopped))
            queued = [job.id for job in repo.jobs_with_status("queued")]
        for job_id in queued:
            self.submit(job_id)
        return len(interrupted), len(queued)

    def shutdown(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)
