"""Real API processes and Celery workers on one database and broker, for the distributed job tests and the
benchmark: started, polled, killed (-9) and restarted like a deployment's."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.error
import urllib.request
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from harness.live import ROOT, free_port, wait_ready
from harness.records import records
from models import iwr, sample_workspace
from models.simulation import perturbed_robot

RABBITMQ = os.environ.get("IWR_TEST_RABBITMQ", "amqp://guest:guest@127.0.0.1:5672//")
REDIS = os.environ.get("IWR_TEST_REDIS", "redis://127.0.0.1:6379/0")


def campaign(poses: int, seed: int = 4) -> dict[str, Any]:
    """A calibration request: `poses` simulated measurements of a perturbed IWR."""
    desc = iwr()
    sim = perturbed_robot(desc, seed=6)
    return {"measurements": records(desc, sim, sample_workspace(desc, poses, seed=3), seed=seed)}


def call(base: str, method: str, path: str, body: Any = None, timeout: float = 30) -> tuple[int, Any]:
    data = None if body is None else json.dumps(body).encode()
    request = urllib.request.Request(
        base + path, data=data, method=method, headers={"content-type": "application/json"}
    )
    try:
        with urllib.request.urlopen(request, timeout=timeout) as r:
            return r.status, json.loads(r.read() or b"null")
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read() or b"null")


@dataclass
class Fleet:
    """Processes sharing `env` (database, broker, a queue of their own so parallel runs never mix)."""

    database_url: str
    broker_url: str
    logs: Path
    extra: dict[str, str] = field(default_factory=dict)
    apis: dict[str, tuple[subprocess.Popen[bytes], str]] = field(default_factory=dict)
    workers: dict[str, subprocess.Popen[bytes]] = field(default_factory=dict)
    queue: str = field(default_factory=lambda: f"iwr-test-{uuid.uuid4().hex[:10]}")

    def env(self) -> dict[str, str]:
        return {
            **os.environ,
            "DATABASE_URL": self.database_url,
            "IWR_BROKER_URL": self.broker_url,
            "IWR_JOB_QUEUE": self.queue,
            "IWR_LOG_LEVEL": "INFO",
            "PYTHONPATH": str(ROOT),
            **self.extra,
        }

    def _popen(self, name: str, args: list[str], **own: str) -> subprocess.Popen[bytes]:
        with (self.logs / f"{name}.log").open("ab") as log:  # the child keeps its own descriptor
            return subprocess.Popen(
                [sys.executable, *args],
                cwd=ROOT,
                env={**self.env(), **own},
                stdout=log,
                stderr=subprocess.STDOUT,
                start_new_session=True,
            )

    def start_api(self, name: str) -> str:
        port = free_port()
        # The APIs here queue jobs and read their rows; the workers compute. So no compute process and no warm-up
        # in an API (what a request needs is built on its first use): ~2.7 s less CPU per API start, a third of
        # what these tests spend, on a machine whose other tests share the cores.
        process = self._popen(
            name,
            ["-m", "service", "--host", "127.0.0.1", "--port", str(port)],
            IWR_COMPUTE_PROCESSES="0",
            IWR_WARM_UP="0",
        )
        base = f"http://127.0.0.1:{port}"
        if not wait_ready(base, process, 120):
            raise RuntimeError(f"API {name} did not start: {(self.logs / f'{name}.log').read_text()[-3000:]}")
        self.apis[name] = (process, base)
        return base

    def start_worker(self, name: str, **own: str) -> subprocess.Popen[bytes]:
        """`own`: environment of this worker alone (e.g. a crash point, `service.compute.faults`)."""
        process = self._popen(name, ["-m", "service.worker"], **own)
        self.workers[name] = process
        return process

    def wait_ready(self, name: str, timeout: float = 120) -> None:
        """Until the worker's process has built its runtime (its log says so)."""
        deadline = time.monotonic() + timeout
        while "runtime built" not in (self.logs / f"{name}.log").read_text():
            if self.workers[name].poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"worker {name} did not start: {(self.logs / f'{name}.log').read_text()[-3000:]}")
            time.sleep(0.1)

    def base(self, name: str) -> str:
        return self.apis[name][1]

    def kill_api(self, name: str) -> None:
        process, _ = self.apis.pop(name)
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)

    def kill_worker(self, name: str) -> None:
        """kill -9 of the whole worker: its main process and the pool process running the job."""
        process = self.workers.pop(name)
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)

    def stop(self) -> None:
        _terminate([p for p, _ in self.apis.values()] + list(self.workers.values()))
        self.apis.clear()
        self.workers.clear()

    def stop_workers(self) -> None:
        """The workers only (SIGTERM: each finishes its job first); the APIs keep serving."""
        _terminate(list(self.workers.values()))
        self.workers.clear()


def _terminate(processes: list[subprocess.Popen[bytes]]) -> None:
    for process in processes:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGTERM)
    for process in processes:
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


@contextmanager
def fleet(database_url: str, broker_url: str, logs: Path, **extra: str) -> Iterator[Fleet]:
    running = Fleet(database_url, broker_url, logs, extra=extra)
    try:
        yield running
    finally:
        running.stop()


def wait_for(base: str, job_ids: list[str], timeout: float = 300, poll: float = 0.05) -> dict[str, dict[str, Any]]:
    """Poll until every job has ended; their final views.

    One job at a time, in submission order, one request per `poll`: polling all of them every round (200 GETs
    every 50 ms) took a core of this 2-core machine from the workers whose progress it was waiting for. A job
    that ended while an earlier one was awaited answers at its first request."""
    deadline = time.monotonic() + timeout
    done: dict[str, dict[str, Any]] = {}
    for job_id in job_ids:
        while True:
            status, job = call(base, "GET", f"/v1/jobs/{job_id}")
            if status == 200 and job["status"] in ("succeeded", "failed", "cancelled"):
                done[job_id] = job
                break
            if time.monotonic() > deadline:
                missing = [j for j in job_ids if j not in done]
                raise AssertionError(f"{len(missing)} jobs did not end, e.g. {job}")
            time.sleep(poll)
    return done
