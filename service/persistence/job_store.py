"""The job row's state machine, moved only by compare-and-set: every change is one `UPDATE … WHERE` whose
condition is the state it expects, checked by the row count, so two processes can never both win a move.

    queued ──claim──▶ running ──succeed (in the result's own transaction)──▶ succeeded
      │                 │ ├─fail──▶ failed         (the error the synchronous request would have answered)
      │                 │ ├─cancel─▶ cancelled     (at a progress point after DELETE; nothing written)
      │                 │ └─lease expired──▶ queued again (requeue / take-over), up to `max_attempts`
      └─DELETE─▶ cancelled                          then ▶ failed with the reason

A worker holds a job by its `worker` name and a lease (`lease_expires_at`) that its heartbeat renews. Every
move out of `running` names the worker, so a worker that lost its lease (expired and taken over) can write
nothing: its final transaction, result included, rolls back. Times are the processes' UTC clocks; leases
(seconds) are far longer than the skew of NTP-synchronised machines (milliseconds).
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

from sqlalchemy import CursorResult, Select, func, select, update
from sqlalchemy.orm import Session

from service.persistence.tables import Job

FINAL = frozenset({"succeeded", "failed", "cancelled"})


class LeaseLost(Exception):
    """This worker no longer holds the job (its lease expired and another took it, or it was cancelled)."""


@dataclass(frozen=True)
class Claim:
    """The job this worker now holds: what it needs to run it."""

    job_id: str
    kind: str
    robot_id: str
    request: dict[str, Any]
    attempt: int


@dataclass(frozen=True)
class NotClaimed:
    """Why a claim did not take the job: `status` as found (or as just set), and for a job another worker
    holds with a live lease, the seconds until that lease expires (when to try again)."""

    status: str
    held_for: float = 0.0


def _expired(now: datetime) -> Any:
    # No lease at all: a job started before leases existed (migration 0003), whose process is gone.
    return Job.lease_expires_at.is_(None) | (Job.lease_expires_at < now)


def utcnow() -> datetime:
    return datetime.now(UTC)


class JobStore:
    """Job-state moves inside the caller's transaction (`Database.session()`)."""

    def __init__(self, session: Session) -> None:
        self.s = session

    def _cas(self, job_id: str, *where: Any, **values: Any) -> bool:
        statement = update(Job).where(Job.id == job_id, *where).values(**values)
        result = self.s.execute(statement.execution_options(synchronize_session=False))
        assert isinstance(result, CursorResult)
        return int(result.rowcount) == 1

    def _held(self, job_id: str, holder: str, **values: Any) -> bool:
        """Move a job `holder` still runs: False once another worker has taken it over (its lease lost)."""
        return self._cas(job_id, Job.status == "running", Job.worker == holder, **values)

    def _end(self, job_id: str, holder: str, status: str, **values: Any) -> bool:
        """End a job `holder` still runs: its lease let go, finished now."""
        return self._held(job_id, holder, status=status, lease_expires_at=None, finished_at=utcnow(), **values)

    # ---------------------------------------------------------------- submission and reads
    def add(self, job_id: str, kind: str, robot_id: str, request: dict[str, Any]) -> Job:
        job = Job(id=job_id, kind=kind, robot_id=robot_id, request=request, status="queued", attempts=0)
        self.s.add(job)
        self.s.flush()
        return job

    def get(self, job_id: str) -> Job | None:
        return self.s.get(Job, job_id)

    def count(self, status: str) -> int:
        return int(self.s.scalar(select(func.count()).select_from(Job).where(Job.status == status)) or 0)

    def page(self, *, status: str | None, kind: str | None, robot_id: str | None, limit: int, offset: int) -> list[Job]:
        query: Select[tuple[Job]] = select(Job)
        if status is not None:
            query = query.where(Job.status == status)
        if kind is not None:
            query = query.where(Job.kind == kind)
        if robot_id is not None:
            query = query.where(Job.robot_id == robot_id)
        # id breaks ties: jobs submitted within the clock's resolution keep one order across pages
        query = query.order_by(Job.created_at.desc(), Job.id.desc()).limit(limit).offset(offset)
        return list(self.s.scalars(query))

    def queued_ids(self) -> list[str]:
        return list(self.s.scalars(select(Job.id).where(Job.status == "queued").order_by(Job.created_at)))

    def durations(self) -> list[tuple[str, int, float]]:
        """(kind, succeeded jobs, summed run seconds) from the rows, for /metrics in any process."""
        rows = self.s.execute(
            select(Job.kind, Job.started_at, Job.finished_at).where(
                Job.status == "succeeded", Job.started_at.is_not(None), Job.finished_at.is_not(None)
            )
        ).all()
        totals: dict[str, tuple[int, float]] = {}
        for kind, started, finished in rows:
            assert started is not None and finished is not None  # the query's condition
            count, seconds = totals.get(kind, (0, 0.0))
            totals[kind] = (count + 1, seconds + max(0.0, (finished - started).total_seconds()))
        return [(kind, count, seconds) for kind, (count, seconds) in sorted(totals.items())]

    # ---------------------------------------------------------------- the worker's moves
    def claim(self, job_id: str, worker: str, *, lease: float, max_attempts: int) -> Claim | NotClaimed:
        """Take a queued job, or one whose holder's lease expired, for `lease` seconds; at most one caller
        wins. A job out of attempts is failed here, with the reason."""
        now = utcnow()
        start = {
            "status": "running",
            "worker": worker,
            "lease_expires_at": now + timedelta(seconds=lease),
            "attempts": Job.attempts + 1,
            "started_at": now,
            "progress": {"stage": "started", "fraction": 0.0},
        }
        live = Job.attempts < max_attempts
        taken = self._cas(job_id, Job.status == "queued", Job.cancel_requested.is_(False), live, **start) or self._cas(
            job_id, Job.status == "running", Job.lease_expires_at < now, live, **start
        )
        job = self.get(job_id)
        if job is None:
            return NotClaimed("missing")
        if taken:
            self.s.refresh(job)
            return Claim(job.id, job.kind, job.robot_id, dict(job.request), job.attempts)
        if job.status in FINAL:
            return NotClaimed(job.status)
        if job.status == "queued" and job.cancel_requested:
            self._cas(job_id, Job.status == "queued", status="cancelled", finished_at=now)
            return NotClaimed("cancelled")
        expired = job.status == "queued" or job.lease_expires_at is None or job.lease_expires_at < now
        if expired and job.attempts >= max_attempts:
            self.give_up(job_id, job.attempts)
            return NotClaimed("failed")
        held = (job.lease_expires_at - now).total_seconds() if job.lease_expires_at else 0.0
        return NotClaimed(job.status, held_for=max(0.0, held))

    def give_up(self, job_id: str, attempts: int) -> bool:
        """Fail a job whose lease expired on its last allowed attempt (each worker stopped mid-way)."""
        now = utcnow()
        error = {
            "type": "https://iwr-calibration.example/problems/retries-exhausted",
            "title": "Retries exhausted",
            "status": 503,
            "detail": f"the worker running this job stopped {attempts} times (its lease expired each time); "
            "not retried again",
            "attempts": attempts,
        }
        return self._cas(
            job_id,
            (Job.status == "queued") | ((Job.status == "running") & _expired(now)),
            status="failed",
            error=error,
            worker=None,
            lease_expires_at=None,
            finished_at=now,
        )

    def renew(self, job_id: str, worker: str, *, lease: float, progress: dict[str, Any] | None) -> bool | None:
        """Extend the lease (and store the latest progress): None if this worker lost the job, else whether a
        cancellation was requested."""
        values: dict[str, Any] = {"lease_expires_at": utcnow() + timedelta(seconds=lease)}
        if progress is not None:
            values["progress"] = progress
        if not self._held(job_id, worker, **values):
            return None
        return bool(self.s.scalar(select(Job.cancel_requested).where(Job.id == job_id)))

    def succeed(self, job_id: str, worker: str, result_id: str) -> None:
        """In the transaction that writes the result: raises `LeaseLost` (rolling it all back) unless this
        worker still holds the job."""
        done = self._end(job_id, worker, "succeeded", result_id=result_id, progress={"stage": "done", "fraction": 1.0})
        if not done:
            raise LeaseLost(f"job {job_id} is no longer held by {worker}")

    def fail(self, job_id: str, worker: str, error: dict[str, Any]) -> bool:
        return self._end(job_id, worker, "failed", error=error)

    def cancelled(self, job_id: str, worker: str) -> bool:
        """A running job stopped at a progress point after its cancellation was requested."""
        return self._end(job_id, worker, "cancelled")

    def release(self, job_id: str, worker: str) -> bool:
        """Give a job back without counting the attempt (its worker is shutting down, not crashing)."""
        return self._held(
            job_id,
            worker,
            status="queued",
            worker=None,
            lease_expires_at=None,
            attempts=Job.attempts - 1,
            progress=None,
        )

    # ---------------------------------------------------------------- anyone's moves
    def fail_unsent(self, job_id: str, error: dict[str, Any]) -> bool:
        """A job whose message could not be published (the broker is down) fails at once, not waits forever."""
        return self._cas(job_id, Job.status == "queued", status="failed", error=error, finished_at=utcnow())

    def request_cancel(self, job_id: str) -> bool:
        """A queued job is cancelled at once; a running one is flagged for its worker. False if finished."""
        now = utcnow()
        if self._cas(job_id, Job.status == "queued", status="cancelled", cancel_requested=True, finished_at=now):
            return True
        return self._cas(job_id, Job.status == "running", cancel_requested=True)

    def held_by(self, worker: str) -> list[str]:
        return list(self.s.scalars(select(Job.id).where(Job.status == "running", Job.worker == worker)))

    def requeue_expired(self, max_attempts: int) -> tuple[list[tuple[str, str]], list[str]]:
        """Jobs whose holder stopped renewing: (put back in the queue, failed as out of attempts). Only
        expired leases are touched, one CAS each: a live job of any process is never changed."""
        now = utcnow()
        expired = self.s.execute(
            select(Job.id, Job.kind, Job.attempts).where(Job.status == "running", _expired(now))
        ).all()
        requeued: list[tuple[str, str]] = []
        failed: list[str] = []
        for job_id, kind, attempts in expired:
            if attempts >= max_attempts:
                if self.give_up(job_id, attempts):
                    failed.append(job_id)
            elif self._cas(
                job_id,
                Job.status == "running",
                _expired(now),
                status="queued",
                worker=None,
                lease_expires_at=None,
            ):
                requeued.append((job_id, kind))
        return requeued, failed
