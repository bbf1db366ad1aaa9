"""Simulated measurements in the API's boundary units, and waiting for a job over the API."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from fastapi.testclient import TestClient

from models import RobotDescription
from models.simulation import SimulatedRobot, measure


def records(
    desc: RobotDescription, sim: SimulatedRobot, joints: np.ndarray, seed: int, *, position_only: bool = False
) -> list[dict[str, object]]:
    campaign = measure(sim, joints, seed=seed, position_only=position_only)
    out = []
    for k in range(campaign.size):
        rec: dict[str, object] = {
            "joints": (campaign.joints[k] * desc.joint_to_boundary).tolist(),
            "position": campaign.positions[k].tolist(),
        }
        if campaign.quaternions is not None:
            rec["orientation"] = campaign.quaternions[k].tolist()
        out.append(rec)
    return out


def finished_job(client: TestClient, url: str, *, seconds: float = 30.0) -> dict[str, Any]:
    """The job at `url` (its status URL) once it has succeeded or failed, polled every 50 ms."""
    deadline = time.monotonic() + seconds
    while True:
        job: dict[str, Any] = client.get(url).json()
        if job["status"] in ("succeeded", "failed"):
            return job
        if time.monotonic() > deadline:
            raise AssertionError(f"job {url} did not finish in {seconds:g} s: {job}")
        time.sleep(0.05)
