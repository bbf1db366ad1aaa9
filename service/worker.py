"""`python -m service.worker [celery worker options]`: a job worker of the Celery engine, on any machine that
reaches the database and the broker (`DATABASE_URL`, `IWR_BROKER_URL`; the other settings as for the API).

It wraps `celery worker`: prefork pool of `IWR_WORKER_CONCURRENCY` processes (default 1: run more workers
rather than more processes per worker, `docker compose up --scale worker=N`), one message prefetched per
process. Each process builds its engine, model cache and registry of robot runtimes once (`start_worker`,
`service.compute.registry.build_registry`) and exits when the worker's main process is gone. SIGTERM drains (Celery's
warm shutdown): no new job is taken, the running one finishes; a second SIGTERM, or SIGKILL, stops at once, and
the job's lease then expires into a requeue.
"""

from __future__ import annotations

import os
import socket
import sys

# Before numpy loads (as in `python -m service`): one job per process, small dense algebra, where BLAS threads
# only contend with the other processes.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from typing import Any  # noqa: E402

from celery.signals import worker_process_init  # noqa: E402

from service import logs  # noqa: E402
from service.jobs.engine import celery_app  # noqa: E402
from service.jobs.runner import start_worker  # noqa: E402
from service.settings import Settings  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    settings = Settings()
    if not settings.broker_url:
        sys.exit(
            "python -m service.worker: set IWR_BROKER_URL (amqp://… or redis://…); without a broker the API "
            "runs jobs in its own embedded pool"
        )
    logs.configure(settings.log_level)
    app = celery_app(settings)
    main_pid = os.getpid()

    def init_process(**_: Any) -> None:
        start_worker(settings, parent=main_pid)

    worker_process_init.connect(init_process, weak=False)
    app.worker_main(
        [
            "worker",
            "--pool=prefork",
            f"--concurrency={settings.worker_concurrency}",
            "--prefetch-multiplier=1",
            f"--queues={settings.job_queue}",
            f"--hostname=iwr-{main_pid}@{socket.gethostname()}",
            f"--loglevel={settings.log_level}",
            # Nothing here uses worker-to-worker messages; without them a worker starts ~1 s sooner.
            "--without-gossip",
            "--without-mingle",
            "--without-heartbeat",
            *(sys.argv[1:] if argv is None else argv),
        ]
    )


if __name__ == "__main__":
    main()
