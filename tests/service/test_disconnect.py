"""A client that hangs up stops its computation: a live server, one compute process, a calibration near the
synchronous budget whose client closes its socket mid-fit (IPOPT stops at its next iteration, nothing stored)."""

from __future__ import annotations

import json
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from harness.live import running_server
from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from service.compute import limits
from tests.service.helpers import records

pytestmark = [pytest.mark.slow, pytest.mark.serial]  # freed time against the full calibration time: alone on the cores

DESC = iwr()
POSES = int(0.9 * limits.SYNC_BUDGET_S / limits.CALIBRATION_S_PER_RECORD)  # ~5 000: just within the budget
HANG_UP_FRACTION = 0.25
"""The client hangs up a quarter into the time the same calibration took with its client waiting (1.9-8 s here,
idle to loaded): mid-fit, whatever the machine's speed."""


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    database: Path = tmp_path_factory.mktemp("gone") / "gone.db"
    with running_server(
        f"sqlite:///{database}",
        IWR_JOB_WORKERS="0",
        IWR_COMPUTE_PROCESSES="1",
        IWR_COMPUTE_DEADLINE_SECONDS="120",  # the connected run must finish, however loaded this machine is
    ) as url:
        yield url


def test_a_client_that_hangs_up_stops_its_calibration(server: str) -> None:
    sim = perturbed_robot(DESC, seed=41)
    body = json.dumps(
        {"measurements": records(DESC, sim, sample_workspace(DESC, POSES, seed=42), seed=43), "apply": False}
    ).encode()
    few = {"joints": (sample_workspace(DESC, 20, seed=44) * DESC.joint_to_boundary).tolist()}  # >16: a compute slot
    with httpx.Client(base_url=server, timeout=120) as http:
        robot = http.post("/v1/robots", json={"name": "gone"}).json()["id"]
        path = f"/v1/robots/{robot}/calibrations"
        started = time.perf_counter()
        assert http.post(path, content=body, headers={"content-type": "application/json"}).status_code == 201
        full_s = time.perf_counter() - started  # the whole calibration, its client waiting
        assert full_s > 1.0, full_s  # long enough for a hang-up to land mid-fit and its stop to show

        port = int(server.rsplit(":", 1)[1])
        head = (
            f"POST {path} HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n"
        )
        with socket.create_connection(("127.0.0.1", port)) as sock:
            sock.sendall(head.encode() + body)
            time.sleep(HANG_UP_FRACTION * full_s)
        hung_up = time.perf_counter()
        # The only compute process is busy with the abandoned fit until it stops; this request waits for it.
        assert http.post(f"/v1/robots/{robot}/forward-kinematics", json=few).status_code == 200
        freed_s = time.perf_counter() - hung_up
        stored = http.get(path).json()
    assert freed_s < 0.5 * full_s, (freed_s, full_s)  # stopped, not run to its end
    assert len(stored) == 1  # the abandoned calibration stored nothing
