"""Running one job exactly once in effect, whoever delivers it and however often, and the embedded pool.

`execute_job` is the whole protocol, shared by the embedded pool and the Celery workers: claim the row by
compare-and-set (`JobStore.claim`: one winner), hold it with a lease that a heartbeat thread renews, run the
use case with hooks that stop it at a progress point when it was cancelled or its lease was lost, and write
`succeeded` inside the use case's own write transaction (result, parameter version and job state commit
together, or nothing does). A second delivery of the same job finds it running under a live lease (and is
told how long to wait) or finished, and changes nothing.

Recovery without a global sweep: a process requeues only jobs whose lease expired (`JobStore.requeue_expired`,
one CAS per job, periodically in each API process); no process ever fails another's live job.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import signal
import socket
import threading
import time
from collections.abc import Callable
from concurrent.futures import Executor, Future, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from sqlalchemy.orm import Session

from models import Registry
from models.engine.cancellation import CancellationToken, Cancelled, Step, cancellable
from service.compute import processes
from service.compute.faults import crash_point
from service.compute.limits import JOB_MEMORY_BYTES
from service.compute.model_cache import ModelCache
from service.compute.parent_watch import watch_parent
from service.compute.pool import resident_bytes
from service.compute.registry import build_registry, native_functions
from service.errors import WorkTooLarge
from service.http.problems import lookup, to_problem
from service.persistence import Database
from service.persistence.job_store import Claim, JobStore, LeaseLost, NotClaimed
from service.services.jobs import run_job
from service.settings import Settings

log = logging.getLogger("service.jobs")

STAGE_SHARE = {"identifying": 0.9}
"""Of the whole job, the share of the stage a solver's iterations advance (calibrate: identifying 0.05 → 0.95)."""
SOLVE_FRACTION_CAP = 0.95
"""A solve past the iterations such solves take is not done: its share stops short of the next stage."""
PROGRESS_WRITE_SECONDS = 0.25
"""A progress point writes to the database at most this often (the heartbeat stores the latest anyway): a
60-pose calibration takes ~30 ms, and three extra transactions would cost it ~10 % of its latency."""
CEILING_WATCH_S = 0.1
"""How often a job's process reads its own resident memory (a read of /proc/self/statm: ~20 us)."""
HARD_MEMORY_FACTOR = 2
"""A job past its memory ceiling is told to stop at its next step; one that keeps growing to this many times the
ceiling is in code with no step (a parse): its row is failed and its process ends itself (the Celery pool, or
the embedded runner, starts another)."""


@dataclass(frozen=True)
class WorkerContext:
    """What one process needs to run jobs, created once: its engine, its model cache, its robot runtimes, the
    lease policy."""

    db: Database
    models: ModelCache
    registry: Registry
    lease: float = 10.0
    max_attempts: int = 3
    memory_bytes: int | None = None
    """How far one job may grow its process above the process's size when it started (None: no ceiling; only
    a process of its own has one: in the API's threads, the API's other work would count as the job's)."""
    time_limit: Callable[[str], float] | None = None
    """A job kind's seconds (Settings.time_limit); past them, the job stops at its next step and fails."""

    @property
    def name(self) -> str:
        """host:pid, stored in the row of the job this process holds."""
        return f"{socket.gethostname()}:{os.getpid()}"


@dataclass(frozen=True)
class Outcome:
    """What one delivery did: the job's status afterwards, and for a job another worker holds, the seconds
    until its lease expires (the delivery should come back then)."""

    status: str
    held_for: float = 0.0
    ran: bool = False


class Lease:
    """The hooks of one claimed job and the heartbeat thread that keeps its lease.

    A thread is enough: CasADi releases the GIL while IPOPT and the compiled Functions run, and numpy and
    Clarabel do inside their kernels (measured: a 50 ms ticker thread kept ticking through a 0.33 s IPOPT
    solve; tests/service/test_jobs.py checks a lease renewed through a long solve)."""

    def __init__(self, ctx: WorkerContext, job_id: str, worker: str) -> None:
        self.ctx, self.job_id, self.worker = ctx, job_id, worker
        self.lost = False
        self.cancel = False
        self._latest: dict[str, Any] | None = None
        self._stage: tuple[str, float] = ("queued", 0.0)
        self._last_write = time.monotonic()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._beat, name=f"lease-{job_id[:8]}", daemon=True)

    def __enter__(self) -> Lease:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join(timeout=5)

    def _renew(self) -> None:
        with self._lock:
            progress, self._last_write = self._latest, time.monotonic()
        try:
            with self.ctx.db.session() as s:
                answer = JobStore(s).renew(self.job_id, self.worker, lease=self.ctx.lease, progress=progress)
        except Exception:  # a database hiccup: the next beat tries again, well before the lease ends
            log.warning("job %s: lease renewal failed", self.job_id, exc_info=True)
            return
        if answer is None:
            self.lost = True
        elif answer:
            self.cancel = True

    def _beat(self) -> None:
        while not self._stop.wait(self.ctx.lease / 3) and not self.lost:
            self._renew()

    def progress(self, stage: str, fraction: float) -> None:
        with self._lock:
            self._latest = {"stage": stage, "fraction": round(float(fraction), 4)}
            self._stage = (stage, float(fraction))
            due = time.monotonic() - self._last_write >= PROGRESS_WRITE_SECONDS
        if due:
            self._renew()
        if self.lost:
            raise LeaseLost(f"job {self.job_id}: lease lost")
        if self.cancel:
            raise Cancelled(f"job {self.job_id} cancelled")

    def iterated(self, step: Step) -> None:
        """A solver iteration inside the current stage (the token's `on_step`): the stage's share of the job
        advanced by the iterations such solves take, with the time left. Never raises (it runs inside IPOPT's
        callback); the heartbeat writes it, or the next progress point."""
        with self._lock:
            stage, start = self._stage
            share = STAGE_SHARE.get(stage, 0.0)
            done = step.iteration / step.expected if step.expected else 1 - 1 / (1 + step.iteration / 10)
            fraction = start + share * min(done, SOLVE_FRACTION_CAP)
            eta = step.eta_seconds
            self._latest = {
                "stage": stage,
                "fraction": round(fraction, 4),
                "iteration": step.iteration,
                **({"eta_seconds": round(eta, 3)} if eta is not None else {}),
            }

    def commit(self, session: Session, result_id: str) -> None:
        JobStore(session).succeed(self.job_id, self.worker, result_id)


class Ceiling:
    """A job's memory and time ceiling while it runs, watched by a thread of its own: past either, `exceeded`
    holds the problem the job fails with, and the job's token stops it at its next step (models.engine.cancellation).
    Past `HARD_MEMORY_FACTOR` times the memory ceiling, `on_hard` fails the row and the process kills itself."""

    def __init__(
        self, memory_bytes: int | None, seconds: float | None, on_hard: Callable[[WorkTooLarge], None]
    ) -> None:
        idle = resident_bytes(os.getpid()) if memory_bytes is not None else None
        self.memory_bytes, self.seconds, self.on_hard = memory_bytes, seconds, on_hard
        self.limit = None if idle is None or memory_bytes is None else idle + memory_bytes
        self.started = time.monotonic()
        self.peak = 0
        self.exceeded: WorkTooLarge | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="job-ceiling", daemon=True)

    def __enter__(self) -> Ceiling:
        if self.limit is not None or self.seconds is not None:
            self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)

    def _problem(self, what: str) -> WorkTooLarge:
        return WorkTooLarge(
            what,
            estimated_s=round(time.monotonic() - self.started, 3),
            estimated_bytes=self.peak or None,
            limit_s=float(self.seconds or 0.0),
            limit_bytes=self.memory_bytes,
        )

    def _watch(self) -> None:
        while not self._stop.wait(CEILING_WATCH_S):
            size = resident_bytes(os.getpid()) or 0
            self.peak = max(self.peak, size)
            over = self.limit is not None and size > self.limit
            if self.exceeded is None and over:
                self.exceeded = self._problem(
                    f"the job grew its process by more than the memory ceiling of one job "
                    f"({(self.memory_bytes or 0) / 1e6:.0f} MB; {size / 1e6:.0f} MB resident) and was stopped: split it"
                )
            if self.exceeded is None and self.seconds is not None and time.monotonic() - self.started > self.seconds:
                self.exceeded = self._problem(
                    f"the job ran past the time limit of its kind ({self.seconds:g} s) and was stopped: split it"
                )
            hard = None if self.limit is None else self.limit + (HARD_MEMORY_FACTOR - 1) * (self.memory_bytes or 0)
            if self.exceeded is not None and hard is not None and size > hard:
                self.on_hard(self.exceeded)
                return


def execute_job(job_id: str, context: WorkerContext | None = None) -> Outcome:
    """Deliver one job to this process: run it if it can be claimed, else report why not."""
    ctx = context or _worker
    if ctx is None:
        raise RuntimeError("execute_job outside a worker started by start_worker, and no context given")
    db, worker = ctx.db, ctx.name
    with db.session() as s:
        claim = JobStore(s).claim(job_id, worker, lease=ctx.lease, max_attempts=ctx.max_attempts)
    if isinstance(claim, NotClaimed):
        return Outcome(claim.status, held_for=claim.held_for)
    return _run(ctx, claim, worker)


def _hard_stop(db: Database, job_id: str, worker: str, problem: WorkTooLarge) -> None:
    """A job deaf to its token and still growing: its row failed now (a redelivery then finds it finished), and
    its process ended here."""
    log.error("job %s: %s; its process ends", job_id, problem)
    with contextlib.suppress(Exception), db.session() as s:
        JobStore(s).fail(job_id, worker, to_problem(problem))
    os.kill(os.getpid(), signal.SIGKILL)


def _run(ctx: WorkerContext, claim: Claim, worker: str) -> Outcome:
    db = ctx.db
    started = time.perf_counter()

    hard_stop = functools.partial(_hard_stop, db, claim.job_id, worker)
    seconds = ctx.time_limit(claim.kind) if ctx.time_limit is not None else None
    with Lease(ctx, claim.job_id, worker) as lease, Ceiling(ctx.memory_bytes, seconds, hard_stop) as ceiling:
        # Between progress points too: the solvers and design loops check this token at each step
        # (models.engine.cancellation), and the heartbeat sets `cancel` or `lost` within a third of the lease.
        token = CancellationToken(
            probe=lambda: lease.cancel or lease.lost or ceiling.exceeded is not None, on_step=lease.iterated
        )
        try:
            with cancellable(token):
                run_job(
                    db=db,
                    models=ctx.models,
                    registry=ctx.registry,
                    kind=claim.kind,
                    robot_id=claim.robot_id,
                    request=claim.request,
                    job=lease,
                )
            # The job's row says succeeded in the same commit as what it made; a death here (before the broker's
            # acknowledgement) must cost nothing but a redelivery that finds the job done.
            crash_point("job-committed")
            status = "succeeded"
        except (LeaseLost, Cancelled) as stopped:
            if isinstance(stopped, Cancelled) and ceiling.exceeded is not None and not lease.lost:
                with db.session() as s:
                    JobStore(s).fail(claim.job_id, worker, to_problem(ceiling.exceeded))
                status = "failed"
            elif isinstance(stopped, Cancelled) and not lease.lost:
                with db.session() as s:
                    JobStore(s).cancelled(claim.job_id, worker)
                status = "cancelled"
            else:  # lost at a progress point, or a solver's step saw the token read the lost lease
                log.warning("job %s: lease lost to another worker; nothing written", claim.job_id)
                return Outcome("lost", ran=True)
        except Exception as exc:  # a job records every failure, as the synchronous request would have answered it
            if isinstance(exc, MemoryError):
                exc = ceiling._problem("the job ran out of memory and was stopped: split it")
            if lookup(exc)[0] >= 500:
                log.exception("job %s failed", claim.job_id)
            with db.session() as s:
                JobStore(s).fail(claim.job_id, worker, to_problem(exc))
            status = "failed"
    log.info(
        "job %s (%s) %s in %.3f s, attempt %d",
        claim.job_id,
        claim.kind,
        status,
        time.perf_counter() - started,
        claim.attempt,
    )
    return Outcome(status, ran=True)


_worker: WorkerContext | None = None
"""Set once per worker process by `start_worker`; never in the API's process."""


def start_worker(
    settings: Settings, parent: int | None = None, memory_bytes: int | None = JOB_MEMORY_BYTES
) -> WorkerContext:
    """A worker process's initializer: one engine, one model cache and one registry of robot runtimes
    (`build_registry`: with `settings.warm_up`, every runtime built now), kept for its lifetime. With `parent`,
    the process exits as soon as that process is gone, so a pool never outlives its server (a server killed
    with -9 cannot stop its pool itself). Each job runs under a ceiling (`Ceiling`): `memory_bytes` above the
    process's size, the time limit of its kind."""
    global _worker  # noqa: PLW0603  (an initializer can leave its state only in the worker's module)
    if parent is not None:
        watch_parent(parent)
    started = time.perf_counter()
    registry = build_registry(settings)
    if settings.warm_up:
        log.info(
            "worker %s: runtime built in %.2f s, %s",
            os.getpid(),
            time.perf_counter() - started,
            "compiled Functions" if native_functions(registry) else "CasADi VM (no compiled library)",
        )
    db = Database(settings.database_url)
    _worker = WorkerContext(
        db,
        ModelCache(db),
        registry,
        lease=settings.job_lease_seconds,
        max_attempts=settings.job_max_attempts,
        memory_bytes=memory_bytes,
        time_limit=settings.time_limit,
    )
    return _worker


class Requeuing:
    """What every engine's API side does: hand jobs to workers (`submit`), and requeue expired leases."""

    queue_limit: int = 1000
    retry_after: int = 5

    def __init__(self, context: WorkerContext) -> None:
        self.context = context
        self._stop = threading.Event()
        self._reaper = threading.Thread(target=self._reap_forever, name="job-reaper", daemon=True)

    def submit(self, job_id: str, kind: str = "") -> None:
        raise NotImplementedError

    def start(self) -> None:
        self._reaper.start()

    def reap(self) -> tuple[int, int]:
        """Requeue (and resubmit) jobs whose lease expired; fail those out of attempts."""
        with self.context.db.session() as s:
            requeued, failed = JobStore(s).requeue_expired(self.context.max_attempts)
        for job_id, kind in requeued:
            self.submit(job_id, kind)
        if requeued or failed:
            log.warning("expired leases: %d jobs requeued, %d failed out of attempts", len(requeued), len(failed))
        return len(requeued), len(failed)

    def _reap_forever(self) -> None:
        while not self._stop.wait(self.context.lease / 2):
            try:
                self.reap()
            except Exception:  # the database may be briefly away; the next round tries again
                log.warning("requeue of expired leases failed", exc_info=True)

    def recover(self) -> int:
        return 0

    def unreachable(self) -> str | None:
        """What of the engine's own dependencies does not answer (None: all answer); for `/readyz`."""
        return None

    def shutdown(self) -> None:
        self._stop.set()


class JobRunner(Requeuing):
    """The embedded engine: a pool of `workers` processes (`service.compute.processes`; 0: one thread of this
    process), fed from this process, plus the requeue of expired leases. The default when no broker is configured."""

    def __init__(self, context: WorkerContext, settings: Settings) -> None:
        super().__init__(context)
        self.workers = settings.job_workers
        self.worker_settings = settings.model_copy(update={"database_url": context.db.url})
        self.executor: Executor = self._processes() if self.workers > 0 else ThreadPoolExecutor(max_workers=1)
        self.queue_limit, self.retry_after = settings.job_queue_limit, settings.job_retry_after
        self.futures: set[Future[Outcome]] = set()
        self.start()

    def _processes(self) -> ProcessPoolExecutor:
        # Each pool process builds its own registry (with warm_up: 0.5 s here); the API's is not shared.
        return processes.executor(self.workers, start_worker, self.worker_settings, os.getpid())

    def submit(self, job_id: str, kind: str = "") -> None:
        if self._stop.is_set():
            return
        if isinstance(self.executor, ThreadPoolExecutor):
            future = self.executor.submit(execute_job, job_id, self.context)
        else:
            try:
                future = self.executor.submit(execute_job, job_id)
            except BrokenProcessPool:
                # A worker process died (killed, or ended itself past its memory ceiling): a new pool takes the
                # jobs; those the dead pool held come back when their leases expire.
                log.warning("job pool broken; starting a new one")
                self.executor = self._processes()
                future = self.executor.submit(execute_job, job_id)
        self.futures.add(future)
        future.add_done_callback(lambda f: self._done(f, job_id))

    def _done(self, future: Future[Outcome], job_id: str) -> None:
        self.futures.discard(future)
        if future.cancelled():
            return
        if future.exception() is not None:
            log.error("job worker crashed: %s", future.exception())
            return
        outcome = future.result()
        if outcome.status == "running" and outcome.held_for > 0 and not self._stop.is_set():
            # Held by a worker that may have died: come back when its lease has expired.
            timer = threading.Timer(outcome.held_for + 0.1, self.submit, args=(job_id,))
            timer.daemon = True
            timer.start()

    def recover(self) -> int:
        """After a (re)start: queued jobs are handed to the pool again (a copy another process also runs is
        harmless: the claim lets one through). Running jobs are left to their leases."""
        with self.context.db.reader() as s:
            queued = JobStore(s).queued_ids()
        for job_id in queued:
            self.submit(job_id)
        return len(queued)

    def shutdown(self) -> None:
        """Stop taking jobs; stop the pool's processes now and give their jobs back to the queue (a job cut
        short loses only its computation: nothing of it was written)."""
        self._stop.set()
        self.executor.shutdown(wait=False, cancel_futures=True)
        if isinstance(self.executor, ProcessPoolExecutor):
            # The pool's processes are private to the executor; no public API terminates a busy one.
            processes = list((getattr(self.executor, "_processes", None) or {}).values())
            for process in processes:
                process.terminate()
            for process in processes:
                process.join(timeout=5)
            host = socket.gethostname()
            with self.context.db.session() as s:
                store = JobStore(s)
                for process in processes:
                    for job_id in store.held_by(f"{host}:{process.pid}"):
                        store.release(job_id, f"{host}:{process.pid}")
