"""The HTTP service on loopback: batch FK, single-pose latency under 50 concurrent clients, calibration overhead.

The load generator (`benchmarks/load.py`) keeps 50 connections, each sending a single-pose FK request every
`PERIOD_S` (an open-loop rate, 50 / PERIOD_S requests per second), so the latencies are those of a server
under that load rather than of a queue that a closed loop would build up on two cores.
"""

from __future__ import annotations

import asyncio
import json
import statistics
import tempfile
import time
from collections.abc import Callable

import httpx
import numpy as np

from benchmarks.load import open_loop, request_bytes
from benchmarks.timing import median_of, target
from harness.live import running_server
from models import Registry, RobotDescription, iwr, sample_workspace
from models.campaign import make_campaign
from models.identifiability import structural_identifiability
from models.identification import IdentificationOptions, identify
from models.identification.acceptance import acceptance_checks
from models.kinematics import forward_kinematics
from models.simulation import measure, perturbed_robot
from service.conversions.calibrations import noise_in, options_in, report_out
from service.conversions.kinematics import forward_out, joints_in
from service.conversions.references import described
from service.http.json_bodies import validate_json
from service.schemas.calibrations import CalibrationCreate
from service.schemas.kinematics import ForwardRequest
from service.services.pipelines import WholeCampaign, fitting_in

CLIENTS = 50
PERIOD_S = 0.25
DURATION_S = 10.0


def fk_split(desc: RobotDescription, body: bytes) -> dict[str, float]:
    """Where a 1 000-pose FK request's time goes inside the compute process (median ms of each step, in this
    process): the rest of the request's time is HTTP and the hops between the API and compute processes."""
    registry = Registry()
    runtime = registry.runtime(desc)
    theta = desc.parameters.nominal
    request = validate_json(ForwardRequest, body)
    assert isinstance(request, ForwardRequest)
    q = joints_in(desc, request.joints)
    fk = forward_kinematics(desc, q, theta, runtime=runtime)
    out = forward_out(fk, [])

    def ms(step: Callable[[], object]) -> float:
        return 1e3 * median_of(step, 30)

    return {
        "validate_body": ms(lambda: validate_json(ForwardRequest, body)),
        "joints_to_internal_units": ms(lambda: joints_in(desc, request.joints)),
        "forward_kinematics": ms(lambda: forward_kinematics(desc, q, theta, runtime=runtime)),
        "response_model": ms(lambda: forward_out(fk, [])),
        "response_json": ms(lambda: out.__pydantic_serializer__.to_json(out)),
    }


def _whole(desc: RobotDescription, request: CalibrationCreate) -> WholeCampaign:
    """The request's records as the calibration pipeline converts them (a tracker's: one whole campaign)."""
    fitting = fitting_in(
        desc, request.measurements, described(request), sigma_mm=request.noise.position_mm, payload=request.payload
    )
    assert isinstance(fitting, WholeCampaign)
    return fitting


def calibration_split(desc: RobotDescription, body: dict[str, object]) -> dict[str, float]:
    """Where a 60-pose calibration request's time goes besides HTTP and the database (median ms of each step of
    `service.services.calibrations._fit`, in this process)."""
    registry = Registry()
    runtime = registry.runtime(desc)
    raw = json.dumps(body).encode()
    request = validate_json(CalibrationCreate, raw)
    assert isinstance(request, CalibrationCreate)
    campaign = _whole(desc, request).campaign
    options, noise = options_in(request), noise_in(request)
    theta = desc.parameters.nominal
    result = identify(desc, campaign, noise=noise, nominal=theta, options=options, runtime=runtime)
    chosen = desc.parameters.indices(options.estimate)
    everything = desc.parameters.indices(IdentificationOptions().estimate)
    checks = acceptance_checks(result, expected_rank=result.rank, start_accuracy_mm=None, sigma_mm=0.01)

    def ms(step: Callable[[], object]) -> float:
        return 1e3 * median_of(step, 15)

    return {
        "validate_body": ms(lambda: validate_json(CalibrationCreate, raw)),
        "records_to_campaign": ms(lambda: _whole(desc, request)),
        "identification": ms(
            lambda: identify(desc, campaign, noise=noise, nominal=theta, options=options, runtime=runtime)
        ),
        "identifiability_expected_and_full": ms(
            lambda: (
                structural_identifiability(desc, chosen, campaign.kind, runtime=runtime),
                structural_identifiability(desc, everything, campaign.kind, runtime=runtime),
            )
        ),
        "acceptance_checks": ms(
            lambda: acceptance_checks(result, expected_rank=result.rank, start_accuracy_mm=None, sigma_mm=0.01)
        ),
        "report": ms(lambda: report_out(desc, result, start_values=theta, start_version=1, checks=checks, noise=noise)),
    }


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
            # The body encoded once, as a client that holds its joints as JSON sends it: the request's time is the
            # server's (the client's own json.dumps of 1 000 vectors is ~4 ms more); after one request per compute
            # process (each one's first reads the robot and loads its Functions: ~80 ms).
            fk_body = json.dumps({"joints": joints}).encode()
            fk_path = f"/v1/robots/{robot}/forward-kinematics"
            headers = {"content-type": "application/json"}
            fk_times = []
            for k in range(25):
                started = time.perf_counter()
                r = http.post(fk_path, content=fk_body, headers=headers)
                answer = r.content
                if k >= 4:
                    fk_times.append(time.perf_counter() - started)
                assert r.status_code == 200 and answer.count(b'"position"') == 1000
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
    split = fk_split(desc, fk_body)
    calibration_steps = calibration_split(desc, body)
    calib = statistics.median(calib_times)
    bare_s = statistics.median(bare)
    return {
        "fk_1000_request_s": fk_1000,
        "fk_1000_split_ms": {**split, "http_and_process_hops": 1e3 * fk_1000 - sum(split.values())},
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
        "calibration_60_split_ms": {
            **calibration_steps,
            "http_database_and_process_hops": 1e3 * calib - sum(calibration_steps.values()),
        },
        "identification_60_bare_s": bare_s,
        "targets": [
            target("FK of 1000 joint vectors in one request, warm (s)", fk_1000, 0.02),
            target("single-pose FK p50 at 50 concurrent clients (ms)", float(np.percentile(lat, 50)), 5.0),
            target("single-pose FK p99 at 50 concurrent clients (ms)", float(np.percentile(lat, 99)), 20.0),
            target("60-pose calibration over HTTP, warm (s)", calib, 0.05),
            target("60-pose calibration over HTTP / bare identification", calib / bare_s, 1.5),
        ],
    }
