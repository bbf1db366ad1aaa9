"""A job is a database row (queued → running → succeeded | failed) and a task in a worker process pool.

Restart policy: at start-up, jobs left `running` by a stopped process are marked failed with reason
"interrupted" (their work may have been half done in a worker that died; the client resubmits), and jobs
still `queued` are submitted again, so no accepted job is lost.
"""

from __future__ import annotations

import logging
import multiprocessing
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

from service.errors import Interrupted
from service.model_cache import ModelCache
from service.persistence import Database, Repository
from service.problems import lookup, to_problem
from service.services.jobs import run_job

log = logging.getLogger("service.jobs")


@dataclass(frozen=True)
class WorkerContext:
    """What one process needs to run jobs: its engine and its model cache, created once."""

    db: Database
    models: ModelCache


_worker: WorkerContext | None = None
"""Set once per worker process by `start_worker` (the pool's initializer); never in the app's process."""


def start_worker(database_url: str) -> None:
    """The pool's initializer: one engine and one model cache per worker process, kept for its lifetime.

    (No warm-up here: a worker builds what its first job uses, as before; building every Function and solver
    per worker belongs to the per-structure runtime the models package is getting.)"""
    global _worker  # noqa: PLW0603  (a pool initializer can leave its state only in the worker's module)
    db = Database(database_url)
    _worker = WorkerContext(db, ModelCache(db))


def execute_job(job_id: str, context: WorkerContext | None = None) -> str:
    """Run one job to completion in this process; returns its final status.

    Worker processes use the context their initializer made; in-process runs pass the app's own.
    """
    ctx = context or _worker
    if ctx is None:
        raise RuntimeError("execute_job outside a worker started by start_worker, and no context given")
    db = ctx.db
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
        result_id = run_job(db=db, models=ctx.models, kind=kind, robot_id=robot_id, request=request)
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
    def __init__(self, db: Database, models: ModelCache, workers: int) -> None:
        self.context = WorkerContext(db, models)
        self.executor: Executor = (
            ProcessPoolExecutor(
                max_workers=workers,
                mp_context=multiprocessing.get_context("spawn"),
                initializer=start_worker,
                initargs=(db.url,),
            )
            if workers > 0
            else ThreadPoolExecutor(max_workers=1)
        )
        self.futures: set[Future[str]] = set()

    def submit(self, job_id: str) -> None:
        if isinstance(self.executor, ThreadPoolExecutor):
            future = self.executor.submit(execute_job, job_id, self.context)
        else:
            future = self.executor.submit(execute_job, job_id)
        self.futures.add(future)
        future.add_done_callback(self._done)

    def _done(self, future: Future[str]) -> None:
        self.futures.discard(future)
        if future.exception() is not None:
            log.error("job worker crashed: %s", future.exception())

    def recover(self) -> tuple[int, int]:
        """(interrupted jobs marked failed, queued jobs resubmitted) after a restart."""
        with self.context.db.session() as s:
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
