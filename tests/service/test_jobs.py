"""The job protocol on its own (`service.persistence.job_store`, `service.jobs.runner`), on SQLite and
PostgreSQL: one claim wins, a duplicate delivery changes nothing, leases expire into requeues up to the retry
limit, cancellation, the bounded queue, the list, and the lease renewed through a long IPOPT solve."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from datetime import timedelta
from pathlib import Path
from typing import Any

import casadi as ca
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import update

from harness.fleet import call
from harness.live import ROOT, free_port
from models import Registry, iwr, sample_workspace
from models.engine import cancellation
from models.simulation import perturbed_robot
from service.compute.model_cache import ModelCache
from service.jobs import runner
from service.jobs.runner import Lease, WorkerContext, execute_job
from service.persistence import Database, Repository
from service.persistence.job_store import Claim, JobStore, LeaseLost, NotClaimed, utcnow
from service.persistence.tables import Job, PoseDesignRecord
from service.schemas.robots import RobotCreate
from service.services.robots import create_robot
from tests.service.conftest import make_client
from tests.service.helpers import records

DESC = iwr()


def _request(seed: int = 4, poses: int = 25) -> dict[str, Any]:
    sim = perturbed_robot(DESC, seed=6)
    return {"measurements": records(DESC, sim, sample_workspace(DESC, poses, seed=3), seed=seed)}


def _queued(db: Database, robot_id: str, kind: str = "calibration", request: dict[str, Any] | None = None) -> str:
    with db.session() as s:
        return JobStore(s).add(f"job-{time.perf_counter_ns()}", kind, robot_id, request or _request()).id


def _robot(db: Database) -> str:
    return create_robot(db=db, body=RobotCreate(name="r")).id


def _expire(db: Database, job_id: str) -> None:
    with db.session() as s:
        s.execute(update(Job).where(Job.id == job_id).values(lease_expires_at=utcnow() - timedelta(seconds=1)))


def _count(db: Database, robot_id: str) -> tuple[int, int]:
    """(calibration rows, parameter versions) of the robot."""
    with db.reader() as s:
        repo = Repository(s)
        return len(repo.calibrations(robot_id, 1000, 0)), repo.latest_version(robot_id)


def test_one_claim_wins_among_concurrent_workers(db: Database) -> None:
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)

    def claim(worker: int) -> Claim | NotClaimed:
        with db.session() as s:
            return JobStore(s).claim(job_id, f"w{worker}", lease=30, max_attempts=3)

    with ThreadPoolExecutor(8) as pool:
        answers = list(pool.map(claim, range(8)))
    won = [a for a in answers if isinstance(a, Claim)]
    assert len(won) == 1 and won[0].attempt == 1
    held = [a for a in answers if isinstance(a, NotClaimed)]
    # (a loser may have read its clock before the winner: up to the wait for the write lock over 30 s)
    assert all(a.status == "running" and 0 < a.held_for <= 35 for a in held), held


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_duplicate_delivery_changes_nothing(db: Database, registry: Registry) -> None:
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)
    ctx = WorkerContext(db, ModelCache(db), registry, lease=30, max_attempts=3)
    first = execute_job(job_id, ctx)
    assert first.status == "succeeded"
    with db.reader() as s:
        before = JobStore(s).get(job_id)
        assert before is not None
        snapshot = (before.status, before.result_id, before.finished_at, before.attempts)
    assert execute_job(job_id, ctx).status == "succeeded"  # the same message again
    assert not execute_job(job_id, ctx).ran
    with db.reader() as s:
        after = JobStore(s).get(job_id)
        assert after is not None
        assert (after.status, after.result_id, after.finished_at, after.attempts) == snapshot
    assert _count(db, robot_id) == (1, 2)


def test_a_worker_that_lost_its_lease_writes_nothing(db: Database) -> None:
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)
    with db.session() as s:
        assert isinstance(JobStore(s).claim(job_id, "old", lease=30, max_attempts=3), Claim)
    _expire(db, job_id)
    with db.session() as s:  # another worker takes the expired lease over
        taken = JobStore(s).claim(job_id, "new", lease=30, max_attempts=3)
        assert isinstance(taken, Claim) and taken.attempt == 2
    with pytest.raises(LeaseLost), db.session() as s:
        Repository(s).add_campaign(robot_id, [])
        JobStore(s).succeed(job_id, "old", "nothing")
    with db.reader() as s:
        job = JobStore(s).get(job_id)
        assert job is not None and job.status == "running" and job.worker == "new"
    assert _count(db, robot_id) == (0, 1)


def test_expired_leases_are_requeued_up_to_the_retry_limit(db: Database) -> None:
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)
    live_id = _queued(db, robot_id)
    with db.session() as s:
        assert isinstance(JobStore(s).claim(live_id, "alive", lease=60, max_attempts=2), Claim)
    for attempt in (1, 2):
        with db.session() as s:
            claim = JobStore(s).claim(job_id, f"dies-{attempt}", lease=30, max_attempts=2)
            assert isinstance(claim, Claim) and claim.attempt == attempt
        _expire(db, job_id)
        with db.session() as s:
            requeued, failed = JobStore(s).requeue_expired(max_attempts=2)
        if attempt == 1:
            assert (requeued, failed) == ([(job_id, "calibration")], [])
        else:
            assert (requeued, failed) == ([], [job_id])
    with db.reader() as s:
        store = JobStore(s)
        job, live = store.get(job_id), store.get(live_id)
        assert job is not None and job.status == "failed" and job.error is not None
        assert job.error["attempts"] == 2 and "stopped 2 times" in job.error["detail"]
        assert live is not None and live.status == "running" and live.worker == "alive"  # never touched


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_cancel_a_queued_job_at_once_and_a_running_one_at_its_next_progress_point(
    db: Database, registry: Registry
) -> None:
    robot_id = _robot(db)
    queued = _queued(db, robot_id)
    with db.session() as s:
        assert JobStore(s).request_cancel(queued)
    ctx = WorkerContext(db, ModelCache(db), registry, lease=30, max_attempts=3)
    assert execute_job(queued, ctx).status == "cancelled"  # its message still arrives: nothing runs

    running = _queued(db, robot_id)
    with db.session() as s:
        claim = JobStore(s).claim(running, ctx.name, lease=30, max_attempts=3)
        assert isinstance(claim, Claim)
    with Lease(ctx, running, ctx.name) as lease:
        lease.progress("identifying", 0.5)
        with db.session() as s:
            assert JobStore(s).request_cancel(running)
        time.sleep(0.3)  # past the progress write interval: the next point reads the flag
        with pytest.raises(Exception, match="cancelled"):
            lease.progress("storing", 0.9)
    with db.session() as s:
        assert JobStore(s).cancelled(running, ctx.name)
        assert not JobStore(s).request_cancel(running)  # finished: nothing left to cancel
    assert _count(db, robot_id) == (0, 1)


@pytest.mark.serial  # a 0.3 s lease renewed by a thread during IPOPT: a starved heartbeat would lapse
@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_the_lease_is_renewed_through_a_long_ipopt_solve(db: Database, registry: Registry) -> None:
    """The heartbeat is a thread: it must keep renewing while IPOPT runs (CasADi releases the GIL)."""
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)
    ctx = WorkerContext(db, ModelCache(db), registry, lease=0.3, max_attempts=3)
    with db.session() as s:
        assert isinstance(JobStore(s).claim(job_id, ctx.name, lease=0.3, max_attempts=3), Claim)
    x = ca.MX.sym("x", 20000)
    solver = ca.nlpsol(
        "s",
        "ipopt",
        {"x": x, "f": ca.sumsqr(ca.sin(x) - 0.3) + ca.sumsqr(x[1:] - x[:-1] ** 2)},
        {"print_time": 0, "ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-14},
    )
    seen: list[float] = []
    with Lease(ctx, job_id, ctx.name):
        started = time.monotonic()
        while time.monotonic() - started < 1.0:  # at least 1 s of solving, > 3 leases
            solver(x0=[1.0] * 20000)
            with db.reader() as s:
                job = JobStore(s).get(job_id)
                assert job is not None and job.lease_expires_at is not None
                seen.append((job.lease_expires_at - utcnow()).total_seconds())
    assert min(seen) > 0, f"the lease expired during a solve: {seen}"
    with db.session() as s:
        requeued, _ = JobStore(s).requeue_expired(3)
        assert job_id not in [j for j, _ in requeued]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_queue_full_answers_429_with_retry_after(tmp_path: Path) -> None:
    with make_client(f"sqlite:///{tmp_path}/q.db", job_queue_limit=2, job_retry_after=7) as c:
        rid = c.post("/v1/robots", json={"name": "r"}).json()["id"]
        # The in-process runner's thread would take them: stop it so that they stay queued.
        c.app.state.jobs.shutdown()  # type: ignore[attr-defined]
        body = {"count": 12, "criterion": "D", "candidate_count": 200, "seed": 1}
        for _ in range(2):
            assert c.post(f"/v1/robots/{rid}/pose-designs?async=true", json=body).status_code == 202
        full = c.post(f"/v1/robots/{rid}/pose-designs?async=true", json=body)
        assert full.status_code == 429, full.text
        assert full.headers["retry-after"] == "7"
        assert full.json()["type"].endswith("/queue-full") and full.json()["limit"] == 2
        listed = c.get("/v1/jobs?status=queued").json()
        assert len(listed) == 2 and all(j["status"] == "queued" and j["result"] is None for j in listed)
        # Cancelling one frees a place.
        cancelled = c.delete(f"/v1/jobs/{listed[0]['id']}")
        assert cancelled.status_code == 200 and cancelled.json()["status"] == "cancelled"
        assert c.delete(f"/v1/jobs/{listed[0]['id']}").status_code == 409
        assert c.post(f"/v1/robots/{rid}/pose-designs?async=true", json=body).status_code == 202


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_list_newest_first_with_filters_and_progress(client: TestClient, robot_id: str) -> None:
    body = {"count": 12, "criterion": "D", "candidate_count": 200, "seed": 1}
    ids = [client.post(f"/v1/robots/{robot_id}/pose-designs?async=true", json=body).json()["job_id"] for _ in range(3)]
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        jobs = client.get(f"/v1/jobs?robot_id={robot_id}").json()
        if all(j["status"] == "succeeded" for j in jobs):
            break
        time.sleep(0.1)
    assert [j["id"] for j in jobs] == ids[::-1]
    assert all(j["progress"] == {"stage": "done", "fraction": 1.0} and j["worker"] for j in jobs)
    assert client.get("/v1/jobs?kind=calibration").json() == []
    assert [j["id"] for j in client.get("/v1/jobs?limit=1&offset=1").json()] == [ids[1]]
    one = client.get(f"/v1/jobs/{ids[0]}").json()
    assert one["attempts"] == 1 and one["result"]["poses"]
    metrics = client.get("/metrics").text
    assert 'iwr_jobs_succeeded{kind="pose_design"} 3.0' in metrics
    assert "iwr_jobs_queue_depth 0.0" in metrics and "iwr_jobs_running 0.0" in metrics


def test_two_racing_runs_of_one_job_store_one_result(db: Database, registry: Registry) -> None:
    """Many deliveries of one calibration at once (a redelivery racing the original): one calibration, one
    new parameter version."""
    robot_id = _robot(db)
    job_id = _queued(db, robot_id)
    ctx = WorkerContext(db, ModelCache(db), registry, lease=30, max_attempts=3)
    barrier = threading.Barrier(4)

    def deliver(_: int) -> str:
        barrier.wait()
        return execute_job(job_id, ctx).status

    with ThreadPoolExecutor(4) as pool:
        statuses = list(pool.map(deliver, range(4)))
    assert "succeeded" in statuses
    assert _count(db, robot_id) == (1, 2)


def _running(pid: int) -> bool:
    """Whether `pid` runs: a zombie (dead, not yet reaped by whoever adopted it) does not."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def _children(pid: int) -> set[int]:
    found = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1]) == pid:
                    found.add(int(entry.name))
            except (OSError, IndexError, ValueError):
                continue
    return found


@pytest.mark.slow  # a server with its pool, twice: ~20 s
@pytest.mark.parametrize("stop", [signal.SIGTERM, signal.SIGKILL])
def test_the_embedded_pool_dies_with_its_server(tmp_path: Path, stop: signal.Signals) -> None:
    """Its workers never outlive the server: after SIGTERM (shutdown stops them) and after kill -9 (each
    notices its parent is gone). SIGTERM is a clean stop: status 0 and no semaphores left to the resource
    tracker (service/__main__.py's handler)."""
    port = free_port()
    # One compute process, not one per core: the pool under test is the jobs'; a compute process is ~2 s of CPU
    # to start, and one still has its semaphores for the clean stop to leave none of.
    env = {
        **os.environ,
        "DATABASE_URL": f"sqlite:///{tmp_path}/e.db",
        "IWR_JOB_WORKERS": "2",
        "IWR_WARM_UP": "0",
        "IWR_COMPUTE_PROCESSES": "1",
    }
    server = subprocess.Popen(
        [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port)],
        cwd=ROOT,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=(stderr := (tmp_path / "stderr").open("wb")),
    )
    try:
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 90
        while True:
            try:
                status, robot = call(base, "POST", "/v1/robots", {"name": "r"})
                break
            except OSError:
                assert server.poll() is None and time.monotonic() < deadline, "the server did not start"
                time.sleep(0.2)
        assert status == 201
        body = {"count": 12, "criterion": "D", "candidate_count": 200, "seed": 1}
        for _ in range(2):  # the pool starts its processes with its first jobs
            assert call(base, "POST", f"/v1/robots/{robot['id']}/pose-designs?async=true", body)[0] == 202
        deadline = time.monotonic() + 60
        while len(pool := _children(server.pid)) < 2 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert len(pool) >= 2, pool
        server.send_signal(stop)
        server.wait(timeout=120)  # a bound on a hang, not on speed: a SIGTERM drain took past 30 s at load ~9
        # A process still importing when its server died notices only once its initializer runs: seconds on a
        # loaded machine (measured: over 15 s at load 7), so the wait is long; a dead one returns at once.
        deadline = time.monotonic() + 60
        while (alive := {p for p in pool if _running(p)}) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not alive, f"pool processes {alive} outlived the server ({stop.name})"
        if stop == signal.SIGTERM:
            # The resource tracker, a process of its own, writes its warning when the last holder has gone.
            time.sleep(1)
            log = (tmp_path / "stderr").read_text()
            assert server.returncode == 0, log[-3000:]
            assert "leaked semaphore" not in log, log[-3000:]
    finally:
        if server.poll() is None:
            server.kill()
            server.wait()
        stderr.close()


@pytest.mark.slow  # a 2 000-candidate design, cancelled mid-way: ~5 s
def test_delete_stops_a_running_design_at_its_next_progress_point_and_nothing_is_written(
    client: TestClient, robot_id: str
) -> None:
    body = {"count": 30, "criterion": "D", "candidate_count": 2000, "seed": 1}
    job_id = client.post(f"/v1/robots/{robot_id}/pose-designs?async=true", json=body).json()["job_id"]
    deadline = time.monotonic() + 60
    while (job := client.get(f"/v1/jobs/{job_id}").json())["status"] == "queued" and time.monotonic() < deadline:
        time.sleep(0.01)
    assert job["status"] == "running", job
    answer = client.delete(f"/v1/jobs/{job_id}")
    assert answer.status_code == 200 and answer.json()["cancel_requested"] is True
    while (job := client.get(f"/v1/jobs/{job_id}").json())["status"] == "running" and time.monotonic() < deadline:
        time.sleep(0.05)
    assert job["status"] == "cancelled" and job["result"] is None and job["error"] is None, job
    assert job["progress"]["stage"] != "done"
    db: Database = client.app.state.db  # type: ignore[attr-defined]
    with db.reader() as s:
        assert s.query(PoseDesignRecord).count() == 0
    assert client.delete(f"/v1/jobs/{job_id}").status_code == 409


@pytest.mark.serial  # stopped within 1 s of wall time: alone on the cores
def test_a_cancelled_job_stops_at_its_solvers_next_step_not_at_its_next_progress_point(
    db: Database, registry: Registry, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The job runs under a token (models.engine.cancellation) that reads the lease's flags, so the solvers' own step
    checks (IPOPT's iteration callback, the design loops, IK) stop it: here a use case that only steps, ten
    seconds long, with no progress point after its first."""
    steps: list[float] = []

    def solver_steps(**kwargs: Any) -> None:
        kwargs["job"].progress("identifying", 0.05)
        started = time.perf_counter()
        while time.perf_counter() - started < 10:
            cancellation.check()
            steps.append(time.perf_counter() - started)
            time.sleep(0.01)

    monkeypatch.setattr(runner, "run_job", solver_steps)
    robot_id = _robot(db)
    ctx = WorkerContext(db, ModelCache(db), registry, lease=0.6, max_attempts=3)  # a heartbeat every 0.2 s
    job_id = _queued(db, robot_id)
    with ThreadPoolExecutor(1) as pool:
        running = pool.submit(execute_job, job_id, ctx)
        while not steps:
            time.sleep(0.01)
        time.sleep(0.3)
        with db.session() as s:
            assert JobStore(s).request_cancel(job_id)
        asked = time.perf_counter()
        assert running.result(timeout=30).status == "cancelled"
        stopped = time.perf_counter() - asked
    assert stopped < 1.0 and steps[-1] < 2.0, (stopped, steps[-1])  # the heartbeat's 0.2 s, not the 10 s
    with db.reader() as s:
        job = JobStore(s).get(job_id)
        assert job is not None and job.status == "cancelled"
