"""Jobs on the Celery engine: an API process and 1 or 2 `python -m service.worker` processes on this machine's
PostgreSQL and RabbitMQ. Throughput of 60-pose calibrations (jobs/s, and as a fraction of the bare
identification's rate in one process), and the end-to-end latency of one job: submit → `succeeded` seen by a
client polling every 5 ms, against 1.5× the computation + 50 ms. The computation is the same calibration as a
synchronous request to the same API (identification, report and its three rows on PostgreSQL: 45–55 ms here,
of which the bare identification is ~17 ms); the bare identification's own rate is the throughput reference.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import datetime
from pathlib import Path

import psycopg

from benchmarks.timing import target
from harness.fleet import RABBITMQ, Fleet, call, campaign, fleet
from models import iwr, sample_workspace
from models.campaign import make_campaign
from models.identification import identify
from models.simulation import measure, perturbed_robot

POSTGRES_ADMIN = os.environ.get("IWR_TEST_POSTGRES", "postgresql://postgres@127.0.0.1:5432/postgres")
JOBS = 60
LATENCY_RUNS = 15


@contextmanager
def _database() -> Iterator[str]:
    name = f"iwr_bench_{uuid.uuid4().hex[:10]}"
    with psycopg.connect(POSTGRES_ADMIN, autocommit=True) as admin:
        admin.execute(f'CREATE DATABASE "{name}"')
    try:
        yield f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    finally:
        with psycopg.connect(POSTGRES_ADMIN, autocommit=True) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def _bare_identification() -> float:
    desc = iwr()
    sim = perturbed_robot(desc, seed=6)
    data = measure(sim, sample_workspace(desc, 60, seed=3), seed=4)
    runs = []
    for _ in range(15):
        started = time.perf_counter()
        identify(desc, make_campaign(desc, data.joints, data.positions, data.quaternions))
        runs.append(time.perf_counter() - started)
    return statistics.median(runs[3:])


def _throughput(f: Fleet, base: str, robots: list[str]) -> float:
    body = {**campaign(60), "apply": False}
    started = time.perf_counter()
    ids = []
    for i in range(JOBS):
        status, accepted = call(base, "POST", f"/v1/robots/{robots[i % len(robots)]}/calibrations?async=true", body)
        assert status == 202, accepted
        ids.append(accepted["job_id"])
    pending = set(ids)
    while pending:
        for job_id in list(pending):
            _, job = call(base, "GET", f"/v1/jobs/{job_id}")
            if job["status"] == "succeeded":
                pending.discard(job_id)
            else:
                assert job["status"] in ("queued", "running"), job
        time.sleep(0.02)
    return JOBS / (time.perf_counter() - started)


def _latency(base: str, robot: str) -> tuple[float, float]:
    """Median (end to end, the worker's own run time) of one job at a time."""
    body = {**campaign(60), "apply": False}
    ends, runs = [], []
    for _ in range(LATENCY_RUNS):
        started = time.perf_counter()
        _, accepted = call(base, "POST", f"/v1/robots/{robot}/calibrations?async=true", body)
        while (job := call(base, "GET", accepted["status_url"])[1])["status"] in ("queued", "running"):
            time.sleep(0.005)
        ends.append(time.perf_counter() - started)
        assert job["status"] == "succeeded", job
        runs.append(
            (datetime.fromisoformat(job["finished_at"]) - datetime.fromisoformat(job["started_at"])).total_seconds()
        )
    return statistics.median(ends[2:]), statistics.median(runs[2:])


def _synchronous(base: str, robot: str) -> float:
    body = {**campaign(60), "apply": False}
    runs = []
    for _ in range(LATENCY_RUNS):
        started = time.perf_counter()
        status, answer = call(base, "POST", f"/v1/robots/{robot}/calibrations", body)
        runs.append(time.perf_counter() - started)
        assert status == 201, answer
    return statistics.median(runs[2:])


def run() -> dict[str, object]:
    bare = _bare_identification()
    results: dict[str, float] = {}
    with _database() as url, tempfile.TemporaryDirectory() as tmp, fleet(url, RABBITMQ, Path(tmp)) as f:
        base = f.start_api("api")
        robots = [call(base, "POST", "/v1/robots", {"name": f"cell-{i}"})[1]["id"] for i in range(4)]
        f.start_worker("w1")
        f.wait_ready("w1")  # the worker's start-up (runtime build) is not part of its throughput
        _throughput(f, base, robots)  # warm: first calibration per process, connection pools
        results["synchronous_request_s"] = _synchronous(base, robots[0])
        results["latency_s"], results["latency_worker_run_s"] = _latency(base, robots[0])
        results["throughput_1_worker_per_s"] = _throughput(f, base, robots)
        f.start_worker("w2")
        f.wait_ready("w2")
        _throughput(f, base, robots)
        results["throughput_2_workers_per_s"] = _throughput(f, base, robots)
    bare_rate = 1.0 / bare
    latency_limit = 1.5 * results["synchronous_request_s"] + 0.05
    return {
        "identification_60_bare_s": bare,
        "bare_rate_per_s": bare_rate,
        **results,
        "throughput_1_worker_vs_bare": results["throughput_1_worker_per_s"] / bare_rate,
        "throughput_2_workers_vs_bare": results["throughput_2_workers_per_s"] / bare_rate,
        "scaling_2_vs_1": results["throughput_2_workers_per_s"] / results["throughput_1_worker_per_s"],
        "targets": [
            target(
                "one 60-pose calibration job, submit to succeeded seen by a poll (s)",
                results["latency_s"],
                latency_limit,
            ),
        ],
    }
