"""The HTTP service on loopback: batch FK, single-pose latency under 50 concurrent clients, calibration overhead.

The load generator (`benchmarks/load.py`) keeps 50 connections, each sending a single-pose FK request every
`PERIOD_S` (an open-loop rate, 50 / PERIOD_S requests per second), so the latencies are those of a server
under that load rather than of a queue that a closed loop would build up on two cores.
"""

from __future__ import annotations

import asyncio
import statistics
import tempfile
import time

import httpx
import numpy as np

from benchmarks.load import open_loop, request_bytes
from benchmarks.timing import target
from harness.live import running_server
from models import iwr, sample_workspace
from models.campaign import make_campaign
from models.identification import identify
from models.simulation import measure, perturbed_robot

CLIENTS = 50
PERIOD_S = 0.25
DURATION_S = 10.0


def run() -> dict[str, object]:
    desc = iwr()
    joints = (sample_workspace(desc, 1000, seed=3) * desc.joint_to_boundary).tolist()
    sim = perturbed_robot(desc, seed=1)
    campaign = measure(sim, sample_workspace(desc, 60, seed=4), seed=5)
    assert campaign.quaternions is not None
    body = {
        "measurements": [
            {"joints": (q * desc.joint_to_boundary).tolist(), "position": p.tolist(), "orientation": o.tolist()}
            for q, p, o in zip(campaign.joints, campaign.positions, campaign.quaternions, strict=True)
        ],
        "apply": False,
    }
    with tempfile.TemporaryDirectory() as tmp, running_server(f"sqlite:///{tmp}/bench.db", IWR_JOB_WORKERS="0") as url:
        with httpx.Client(base_url=url, timeout=60) as http:
            robot = http.post("/v1/robots", json={"name": "bench"}).json()["id"]
            fk_times = []
            for _ in range(15):
                started = time.perf_counter()
                r = http.post(f"/v1/robots/{robot}/forward-kinematics", json={"joints": joints})
                fk_times.append(time.perf_counter() - started)
                assert r.status_code == 200 and len(r.json()["poses"]) == 1000
            calib_times = []
            for _ in range(15):
                started = time.perf_counter()
                r = http.post(f"/v1/robots/{robot}/calibrations", json=body)
                calib_times.append(time.perf_counter() - started)
                assert r.status_code == 201 and r.json()["status"] == "succeeded"
        host = url.removeprefix("http://")
        path = f"/v1/robots/{robot}/forward-kinematics"
        prepared = [request_bytes(host, path, {"joints": [j]}) for j in joints[:200]]
        latencies, errors = asyncio.run(open_loop(url, prepared, CLIENTS, PERIOD_S, DURATION_S))
        heavier, heavier_errors = asyncio.run(open_loop(url, prepared, CLIENTS, PERIOD_S / 2.5, DURATION_S))
    bare = []
    for _ in range(15):
        started = time.perf_counter()
        identify(desc, make_campaign(desc, campaign.joints, campaign.positions, campaign.quaternions))
        bare.append(time.perf_counter() - started)
    lat = np.sort(np.array(latencies)) * 1e3
    fk_1000 = statistics.median(fk_times)
    calib = statistics.median(calib_times)
    bare_s = statistics.median(bare)
    return {
        "fk_1000_request_s": fk_1000,
        "single_pose_p50_ms": float(np.percentile(lat, 50)),
        "single_pose_p99_ms": float(np.percentile(lat, 99)),
        "single_pose_requests": int(lat.size),
        "single_pose_errors": errors,
        "offered_rate_per_s": CLIENTS / PERIOD_S,
        "achieved_rate_per_s": lat.size / DURATION_S,
        "at_500_per_s": {
            "p50_ms": float(np.percentile(heavier, 50) * 1e3),
            "p99_ms": float(np.percentile(heavier, 99) * 1e3),
            "achieved_rate_per_s": len(heavier) / DURATION_S,
            "errors": heavier_errors,
        },
        "calibration_60_http_s": calib,
        "identification_60_bare_s": bare_s,
        "targets": [
            target("FK of 1000 joint vectors in one request (s)", fk_1000, 0.1),
            target("single-pose FK p50 at 50 concurrent clients (ms)", float(np.percentile(lat, 50)), 5.0),
            target("single-pose FK p99 at 50 concurrent clients (ms)", float(np.percentile(lat, 99)), 20.0),
            target("60-pose calibration over HTTP / bare identification", calib / bare_s, 1.5),
        ],
    }
