"""A job's ceiling while it runs (service.jobs.runner.Ceiling): its process's memory above the size it had when
the job started, and the time limit of its kind; past either the job stops at its next step and fails with a
work-too-large problem naming the ceiling, and past twice the memory ceiling (code with no step) the row is
failed and the process ends."""

from __future__ import annotations

import time
from typing import Any

import pytest

from models import Registry, iwr, sample_workspace
from models.simulation import perturbed_robot
from service.compute.model_cache import ModelCache
from service.errors import WorkTooLarge
from service.jobs import runner
from service.jobs.runner import Ceiling, WorkerContext, execute_job
from service.persistence import Database
from service.persistence.job_store import JobStore
from service.schemas.robots import RobotCreate
from service.services.robots import create_robot
from tests.service.helpers import records


def _wait(condition: Any, seconds: float = 10.0) -> bool:
    deadline = time.monotonic() + seconds
    while not condition() and time.monotonic() < deadline:
        time.sleep(0.01)
    return bool(condition())


def test_memory_past_the_ceiling_is_named_and_twice_past_it_stops_hard() -> None:
    hard: list[WorkTooLarge] = []
    with Ceiling(50_000_000, None, hard.append) as ceiling:
        assert ceiling.limit is not None
        held = [bytearray(80_000_000)]  # zero-filled: resident at once, 80 MB > 50 MB
        assert _wait(lambda: ceiling.exceeded is not None)
        assert not hard  # past the ceiling, not yet past twice it
        exceeded = ceiling.exceeded
        assert exceeded is not None and exceeded.data["limit_bytes"] == 50_000_000
        assert exceeded.data["estimated_bytes"] > ceiling.limit  # the size it reached, measured
        held.append(bytearray(60_000_000))  # 140 MB above: past 2 x 50 MB
        assert _wait(lambda: bool(hard))
        assert hard[0] is exceeded
    del held


def test_a_job_within_its_ceiling_is_left_alone() -> None:
    with Ceiling(500_000_000, 60.0, lambda _: None) as ceiling:
        time.sleep(0.3)  # three watches
    assert ceiling.exceeded is None


def test_the_time_limit_of_its_kind() -> None:
    with Ceiling(None, 0.2, lambda _: None) as ceiling:
        assert _wait(lambda: ceiling.exceeded is not None, 5.0)
    exceeded = ceiling.exceeded
    assert exceeded is not None and exceeded.data["limit_s"] == 0.2
    assert "time limit" in str(exceeded)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_calibration_job_past_its_ceiling_fails_with_the_problem(
    db: Database, registry: Registry, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(runner, "CEILING_WATCH_S", 0.002)
    monkeypatch.setattr(runner, "HARD_MEMORY_FACTOR", 10**9)  # the hard stop would end this test's process
    robot_id = create_robot(db=db, body=RobotCreate(name="r")).id
    sim = perturbed_robot(iwr(), seed=6)
    request = {"measurements": records(iwr(), sim, sample_workspace(iwr(), 300, seed=3), seed=4)}
    with db.session() as s:
        job_id = JobStore(s).add("job-ceiling", "calibration", robot_id, request).id
    # A ceiling of 1 byte above the process's size: any allocation of the solve passes it, within a watch.
    ctx = WorkerContext(db, ModelCache(db), registry, lease=30, max_attempts=1, memory_bytes=1)
    outcome = execute_job(job_id, ctx)
    assert outcome.status == "failed"
    with db.reader() as s:
        job = JobStore(s).get(job_id)
        assert job is not None and job.error is not None
        assert job.error["type"].endswith("work-too-large") and job.error["limit_bytes"] == 1
        assert job.result_id is None  # nothing of it was written
