"""50 concurrent clients against a running server on loopback: no errors, nothing lost or duplicated."""

from __future__ import annotations

import os
import threading
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from harness.live import running_server
from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from tests.service.helpers import SOAK, records

# A load test: a live server under fifty clients for IWR_CONCURRENCY_SECONDS (5 s in `make test`, 10 s in
# `make soak`).
pytestmark = [pytest.mark.slow, pytest.mark.serial]  # fifty clients for 10 s, latency bounds: alone on the cores

DESC = iwr()
CLIENTS = 50
SECONDS = float(os.environ.get("IWR_CONCURRENCY_SECONDS", "10" if SOAK else "5"))


def test_fifty_clients_under_load(tmp_path: Path) -> None:
    sim = perturbed_robot(DESC, seed=31)
    campaign = records(DESC, sim, sample_workspace(DESC, 20, seed=32), seed=33)
    joints = (sample_workspace(DESC, 64, seed=34) * DESC.joint_to_boundary).tolist()
    with running_server(f"sqlite:///{tmp_path}/load.db", IWR_JOB_WORKERS="0") as url:
        robot = httpx.post(url + "/v1/robots", json={"name": "load"}).json()["id"]
        created: list[list[str]] = [[] for _ in range(CLIENTS)]
        not_applied: list[list[str]] = [[] for _ in range(CLIENTS)]
        errors: list[str] = []
        counts = np.zeros(CLIENTS, dtype=int)
        overloaded = np.zeros(CLIENTS, dtype=int)
        stop = time.monotonic() + SECONDS

        def answered() -> int:
            return sum(len(c) for c in created) + sum(len(c) for c in not_applied)

        def client(k: int) -> None:
            with httpx.Client(base_url=url, timeout=60) as http:
                i = 0
                # For the time, and in any case until half the clients' calibrations were answered: a count of
                # work, not a rate, so a busy machine (CI's cores shared) slows the test instead of failing it.
                # (Until every client's own: 50 IWR fits after the time, most of the test's 35 s.)
                while time.monotonic() < stop or answered() < CLIENTS // 2:
                    i += 1
                    if i % 15 == 0:
                        r = http.post(f"/v1/robots/{robot}/calibrations", json={"measurements": campaign})
                        if r.status_code == 201:
                            created[k].append(r.json()["id"])
                        elif r.status_code == 409:  # another calibration applied meanwhile: stored, not applied
                            not_applied[k].append(r.json()["calibration_id"])
                    else:
                        r = http.post(f"/v1/robots/{robot}/forward-kinematics", json={"joints": [joints[(k + i) % 64]]})
                    if r.status_code == 503 and r.json()["type"].endswith("overloaded"):
                        overloaded[k] += 1  # every compute slot busy: a well-behaved client waits as told
                        time.sleep(float(r.headers["retry-after"]))
                    elif r.status_code >= 300 and r.status_code != 409:
                        errors.append(f"{r.status_code} {r.text[:200]}")
                    counts[k] += 1

        threads = [threading.Thread(target=client, args=(k,)) for k in range(CLIENTS)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()

        assert not errors, errors[:5]
        ids = [i for c in created for i in c]
        kept = [i for c in not_applied for i in c]
        stored = httpx.get(f"{url}/v1/robots/{robot}/calibrations", params={"limit": 1000}).json()
        assert sorted(c["id"] for c in stored) == sorted(ids + kept)  # nothing lost, nothing twice
        assert len(ids) + len(kept) >= CLIENTS // 2 and counts.sum() > 10 * CLIENTS
        assert overloaded.sum() < counts.sum() / 2
        # Every calibration applied made exactly one new version, numbered without gaps; the others none (a 409
        # lost the race; a 201 not applied failed a check: the same campaign again predicts no better).
        applied = [c for c in stored if c["applied"]]
        params = httpx.get(f"{url}/v1/robots/{robot}/parameters").json()
        assert applied and params["version"] == len(applied) + 1
        versions = sorted(c["parameter_version"] for c in applied)
        assert versions == list(range(2, len(applied) + 2))
        assert all(c["parameter_version"] is None and c["not_applied_reason"] for c in stored if not c["applied"])
