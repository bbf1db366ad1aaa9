"""The broker killed (-9) and restarted while jobs are queued and running (issue 31): nothing lost, nothing run
twice, and a submission while it is down is refused rather than stored for a message never sent.

The test starts its own Redis on a spare port (the machine's shared brokers must not be restarted under other
tests), with its append-only file written at every command, as a deployment that keeps its queue would run it.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from harness.fleet import call, campaign, fleet, wait_for
from harness.live import free_port
from tests.service.conftest import postgres_url

pytestmark = pytest.mark.slow  # a fleet started, the broker killed and restarted: ~20 s

REDIS_SERVER = shutil.which("redis-server")
LEASE = "2"
HELD_S = 4.0
"""The first job's branch and bound runs this long (`bound_seconds`): it is running across the whole outage."""


class OwnRedis:
    """A Redis of this test's own: its port and directory; killed with -9 and started again on both."""

    def __init__(self, directory: Path) -> None:
        assert REDIS_SERVER is not None
        self.directory, self.port = directory, free_port()
        directory.mkdir(parents=True, exist_ok=True)
        self.process: subprocess.Popen[bytes] | None = None

    @property
    def url(self) -> str:
        return f"redis://127.0.0.1:{self.port}/0"

    def start(self) -> None:
        assert REDIS_SERVER is not None
        command = [REDIS_SERVER, "--port", str(self.port), "--bind", "127.0.0.1", "--dir", str(self.directory)]
        command += ["--appendonly", "yes", "--appendfsync", "always", "--save", "", "--protected-mode", "no"]
        with (self.directory / "redis.log").open("ab") as log:
            self.process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 20
        while b"Ready to accept connections" not in (self.directory / "redis.log").read_bytes():
            if self.process.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError((self.directory / "redis.log").read_text()[-2000:])
            time.sleep(0.02)

    def kill(self) -> None:
        assert self.process is not None
        os.kill(self.process.pid, signal.SIGKILL)
        self.process.wait(timeout=10)
        # The next start appends to the same log: wait for its own "Ready" line, not this one.
        log = self.directory / "redis.log"
        log.write_bytes(log.read_bytes().replace(b"Ready to accept connections", b"(ready before the kill)"))

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.kill()
            self.process.wait(timeout=10)


@pytest.fixture
def pg() -> Iterator[str]:
    yield from postgres_url()


@pytest.fixture
def redis(tmp_path: Path) -> Iterator[OwnRedis]:
    if REDIS_SERVER is None:
        if os.environ.get("CI") == "true":
            pytest.fail("redis-server must be installed for CI on this machine (apt-get install redis-server)")
        pytest.skip("redis-server is not installed (apt-get install redis-server)")
    own = OwnRedis(tmp_path / "redis")
    own.start()
    try:
        yield own
    finally:
        own.stop()


def _until(base: str, job_id: str, status: str, timeout: float = 120) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        _, job = call(base, "GET", f"/v1/jobs/{job_id}")
        if job["status"] == status:
            return dict(job)
        time.sleep(0.01)
    raise AssertionError(f"job {job_id} never became {status}: {job}")


def test_the_broker_killed_and_restarted_mid_run_loses_and_repeats_nothing(
    pg: str, redis: OwnRedis, tmp_path: Path
) -> None:
    with fleet(pg, redis.url, tmp_path, IWR_JOB_LEASE_SECONDS=LEASE) as f:
        base = f.start_api("api")
        f.start_worker("w")
        f.wait_ready("w")
        _, robot = call(base, "POST", "/v1/robots", {"name": "broker-restart"})
        designs = f"/v1/robots/{robot['id']}/pose-designs?async=true"
        long_design = {"count": 30, "criterion": "D", "candidate_count": 2000, "seed": 1, "bound_seconds": HELD_S}
        status, first = call(base, "POST", designs, long_design)
        assert status == 202, first
        queued = []
        for k in range(3):  # behind the first: queued in the broker when it dies
            status, body = call(
                base, "POST", designs, {"count": 12, "criterion": "D", "candidate_count": 300, "seed": k}
            )
            assert status == 202, body
            queued.append(body["job_id"])
        status, body = call(base, "POST", f"/v1/robots/{robot['id']}/calibrations?async=true", campaign(40))
        assert status == 202, body
        queued.append(body["job_id"])
        _until(base, first["job_id"], "running")

        redis.kill()
        # While it is down: refused with 503 (the job recorded as failed, never run later), not a 202 for a
        # message that was never sent.
        status, refused = call(base, "POST", designs, {"count": 12, "criterion": "D", "candidate_count": 300})
        assert status == 503 and refused["type"].endswith("/not-ready"), refused
        time.sleep(1.0)
        redis.start()

        ended = wait_for(base, [first["job_id"], *queued], timeout=240)
        assert {j["status"] for j in ended.values()} == {"succeeded"}, ended
        # The running job was not taken over (its lease was renewed through the outage) nor run again.
        assert ended[first["job_id"]]["attempts"] == 1, ended[first["job_id"]]
        assert all(ended[j]["attempts"] == 1 for j in queued), ended
        _, stored = call(base, "GET", f"/v1/robots/{robot['id']}/pose-designs?limit=100")
        assert sorted(d["id"] for d in stored) == sorted(
            ended[j]["result"]["id"] for j in [first["job_id"], *queued[:3]]
        )
        _, calibrations = call(base, "GET", f"/v1/robots/{robot['id']}/calibrations")
        assert [c["id"] for c in calibrations] == [ended[queued[3]]["result"]["id"]]
        _, failed = call(base, "GET", f"/v1/jobs?robot_id={robot['id']}&status=failed")
        assert len(failed) == 1 and failed[0]["error"]["type"].endswith("/not-ready"), failed
