"""Compensation: 1 000 targets in one call (the library, and through a live server's API, with the API's forward
kinematics of 1 000 poses beside it), one target at a time, and IPOPT alone as the baseline."""

from __future__ import annotations

import json
import os
import statistics
import tempfile
import time
from collections import Counter

import httpx
import numpy as np

from benchmarks.timing import median_of, target
from harness.live import running_server
from models import forward_kinematics, iwr, sample_workspace
from models.compensation import inverse_kinematics
from models.engine.runtime import runtime_for
from models.identification import identify
from models.inverse import default_seed, routing, starts
from models.inverse.problem import joint_weights
from models.simulation import measure, perturbed_robot
from models.transforms import matrix_to_quaternion

API_REPEATS = 9
"""Requests timed per API measurement (after two warm-ups); the median is reported."""


def api_times(positions: np.ndarray, quats: np.ndarray, joints: np.ndarray) -> dict[str, float]:
    """Median seconds of one request with 1 000 targets to inverse-kinematics, and one with 1 000 joint vectors
    to forward-kinematics, on the IWR robot of a live server (its default: the nominal model)."""
    ik_body = json.dumps(
        {
            "targets": [
                {"position": p.tolist(), "orientation": q.tolist()} for p, q in zip(positions, quats, strict=True)
            ]
        }
    ).encode()
    fk_body = json.dumps({"joints": joints.tolist()}).encode()
    headers = {"content-type": "application/json"}
    out: dict[str, float] = {}
    with (
        tempfile.TemporaryDirectory() as tmp,
        running_server(f"sqlite:///{tmp}/bench.db", IWR_JOB_WORKERS="0") as url,
        httpx.Client(base_url=url, timeout=60) as http,
    ):
        robot = http.post("/v1/robots", json={"name": "bench"}).json()["id"]
        for name, path, body in (
            ("ik", f"/v1/robots/{robot}/inverse-kinematics", ik_body),
            ("fk", f"/v1/robots/{robot}/forward-kinematics", fk_body),
        ):
            times = []
            for k in range(API_REPEATS + 2):
                started = time.perf_counter()
                r = http.post(path, content=body, headers=headers)
                if k >= 2:
                    times.append(time.perf_counter() - started)
                assert r.status_code == 200, r.text[:300]
            out[name] = statistics.median(times)
    return out


def run() -> dict[str, object]:
    desc = iwr()
    sim = perturbed_robot(desc, seed=1)
    theta = identify(desc, measure(sim, sample_workspace(desc, 60, seed=11), seed=12)).parameters
    fk = forward_kinematics(desc, sample_workspace(desc, 1000, seed=5), theta)
    positions, quats = fk.positions, matrix_to_quaternion(fk.rotations)

    started = time.perf_counter()
    first = inverse_kinematics(desc, positions[:1], quats[:1], theta)  # builds the table of this calibration
    first_s = time.perf_counter() - started
    batch_s = median_of(lambda: inverse_kinematics(desc, positions, quats, theta), 5)
    # CPU seconds too: on a shared machine the wall time measures the others' load as well.
    batch_cpu_s = median_of(lambda: inverse_kinematics(desc, positions, quats, theta), 5, clock=time.process_time)
    answer = inverse_kinematics(desc, positions, quats, theta)
    single_ms = 1e3 * median_of(lambda: inverse_kinematics(desc, positions[7], quats[7], theta), 50)
    methods = Counter(answer.methods)

    # Baseline: IPOPT on every target from the same starting points (one mapped call).
    n = positions.shape[0]
    target_rows = np.hstack([positions, fk.rotations.transpose(0, 2, 1).reshape(n, 9)])
    table = starts.start_table(desc, theta)
    _, nearest = table.pose_tree.query(starts.features(positions, fk.rotations))
    seeds = np.tile(default_seed(desc), (n, 1))
    started = time.perf_counter()
    batch = routing.IkBatch(
        desc, theta, target_rows, seeds, joint_weights(desc, None), position_only=False, runtime=runtime_for(desc)
    )
    routing.ipopt_solutions(batch, start=table.start[nearest], exact=True)
    ipopt_s = time.perf_counter() - started

    # Through the API: targets the nominal IWR reaches (a new robot's parameters), in mm and a quaternion.
    joints = sample_workspace(desc, 1000, seed=5)
    nominal = forward_kinematics(desc, joints)
    api = api_times(nominal.positions, matrix_to_quaternion(nominal.rotations), joints * desc.joint_to_boundary)
    return {
        "first_call_new_calibration_s": first_s,
        "batch_1000_s": batch_s,
        "batch_1000_cpu_s": batch_cpu_s,
        "single_target_median_ms": single_ms,
        "ipopt_only_1000_s": ipopt_s,
        "speedup_vs_ipopt_only": ipopt_s / batch_s,
        "methods": dict(methods),
        "reachable": int(answer.reachable.sum()),
        "max_position_error_mm": float(np.max(answer.position_error_mm)),
        "first_reachable": bool(first.reachable[0]),
        "api_ik_1000_request_s": api["ik"],
        "api_fk_1000_request_s": api["fk"],
        "load_average_1min_at_end": os.getloadavg()[0],
        "targets": [
            target("1000 targets, one call (s)", batch_s, 0.2),
            target("1000 targets through the API, one request, median (s)", api["ik"], 0.2),
            target("FK of 1000 poses through the API, one request, median (s)", api["fk"], 0.02),
            target("one target, median after warm-up (ms)", single_ms, 20.0),
        ],
    }
