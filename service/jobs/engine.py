"""The distributed engine: Celery over RabbitMQ (or Redis), selected by `IWR_BROKER_URL`.

The broker only carries job ids; the row stays the truth (`service.jobs.runner`). Delivery is at least once:
late acknowledgement (a message is acknowledged after its task returned, and rejected back to the queue when
the worker process is lost), one message prefetched per process (jobs take 0.03–60 s: a prefetched job
would wait behind a long one while another worker idles). The claim's compare-and-set makes a second
delivery harmless; a delivery that finds the job held under a live lease comes back when the lease expires.
"""

from __future__ import annotations

import logging
from typing import Any

from celery import Celery, Task

from service.jobs.runner import Requeuing, WorkerContext, execute_job
from service.settings import Settings

log = logging.getLogger("service.jobs")

TASK = "iwr.run_job"
BROKER_CHECK_S = 1.0
"""How long `/readyz` waits for the broker to accept a connection."""
HARD_LIMIT_GRACE = 30.0
"""Seconds between a kind's soft time limit (the job fails with the reason) and the hard one (the process is
killed: only for a computation that ignores the soft limit inside native code)."""


def celery_app(settings: Settings) -> Celery:
    app = Celery("iwr", broker=settings.broker_url, set_as_current=False)
    transport: dict[str, Any] = {}
    if settings.broker_url.startswith(("redis://", "rediss://")):
        # Redis has no consumer connections to watch: an unacknowledged message returns to the queue only
        # after this long. The lease requeue (seconds) recovers a dead worker's job much sooner; a copy
        # redelivered later finds it done.
        transport["visibility_timeout"] = settings.job_time_limit_pose_design + 2 * HARD_LIMIT_GRACE
    app.conf.update(
        task_acks_late=True,
        task_reject_on_worker_lost=True,
        worker_prefetch_multiplier=1,
        task_default_queue=settings.job_queue,
        task_serializer="json",
        accept_content=["json"],
        task_ignore_result=True,
        broker_connection_retry_on_startup=True,
        broker_transport_options=transport,
        worker_hijack_root_logger=False,
        worker_send_task_events=False,
    )
    app.task(name=TASK, bind=True, acks_late=True, reject_on_worker_lost=True)(run_job_task)
    return app


def run_job_task(task: Task, job_id: str) -> str:
    """One delivery of a job (in a worker process set up by `service.worker`)."""
    outcome = execute_job(job_id)
    if outcome.status == "running" and not outcome.ran:
        # Another worker holds it: it may have died (its message came back to us). Come back when its lease
        # ends; the claim then takes it over, or finds it finished.
        raise task.retry(countdown=outcome.held_for + 0.2, max_retries=None)
    return outcome.status


class CeleryRunner(Requeuing):
    """The API side of the engine: publishes job ids, requeues expired leases (republishing them)."""

    def __init__(self, context: WorkerContext, settings: Settings) -> None:
        super().__init__(context)
        self.settings = settings
        self.app = celery_app(settings)
        self.queue_limit, self.retry_after = settings.job_queue_limit, settings.job_retry_after
        self.start()

    def submit(self, job_id: str, kind: str = "") -> None:
        limit = self.settings.time_limit(kind or "calibration")
        self.app.send_task(
            TASK,
            args=[job_id],
            queue=self.settings.job_queue,
            soft_time_limit=limit,
            time_limit=limit + HARD_LIMIT_GRACE,
            retry=True,
            retry_policy={"max_retries": 3, "interval_start": 0.2, "interval_step": 0.5},
        )

    def recover(self) -> int:
        return 0  # queued jobs wait in the broker, not in this process

    def unreachable(self) -> str | None:
        """The broker, asked for a connection now (not the publisher's pooled one, which reconnects only on its
        next publish): without it no job starts, so the API is not ready (issue 48: /readyz said 200 while
        the broker was down). A refused connection fails in ~5 ms, a silent one after BROKER_CHECK_S."""
        connection = self.app.connection_for_write()
        where = connection.as_uri()  # the password masked
        try:
            with connection:
                connection.ensure_connection(max_retries=1, interval_start=0, interval_step=0, timeout=BROKER_CHECK_S)
        except Exception as exc:  # kombu's OperationalError, a socket error, a timeout: all mean the same here
            return f"the job broker ({where}) does not answer: {exc}"
        return None

    def shutdown(self) -> None:
        super().shutdown()
        self.app.close()
