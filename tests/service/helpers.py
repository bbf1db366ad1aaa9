"""Simulated measurements in the API's boundary units, waiting for a job over the API, and a broker or a skip."""

from __future__ import annotations

import os
import socket
import time
import tracemalloc
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from alembic import command
from alembic.config import Config
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, inspect

from harness.programs import Cell

# The harness builds its campaigns from the same records; the service tests keep importing them from here.
from harness.records import records
from iwr_client.client import Answer, Client
from iwr_client.errors import ApiError
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like, ur5_like_document
from service.persistence.database import MIGRATIONS

__all__ = ["SOAK", "MigratedFile", "assert_design_kept", "broker", "finished_job", "migrated_file", "records"]

UR5 = ur5_like()
SOAK = os.environ.get("IWR_SOAK") == "1"
"""`make soak`: the load and fleet tests at their full length (50 clients for 10 s, 12 s of mixed load, 200 jobs
through the fleet). `make test` runs them shorter: the same assertions, on what only took longer by waiting."""


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


def broker(url: str) -> str:
    """The broker's URL when it answers; otherwise skip (fail under CI, where it must run)."""
    host_port = url.rsplit("@", maxsplit=1)[-1].rsplit("://", maxsplit=1)[-1].split("/", maxsplit=1)[0]
    host, port = host_port.rsplit(":", 1)
    try:
        socket.create_connection((host, int(port)), timeout=2).close()
    except OSError as exc:
        if os.environ.get("CI") == "true":
            pytest.fail(f"the broker {url} must be running for CI on this machine: {exc}")
        pytest.skip(f"no broker at {host}:{port} ({exc})")
    return url


@contextmanager
def cost() -> Iterator[dict[str, float]]:
    """CPU seconds of this process and tracemalloc's peak (MB) over the block: bounds that hold on a busy machine."""
    found: dict[str, float] = {}
    tracemalloc.start()
    started = time.process_time()
    try:
        yield found
    finally:
        found["cpu_s"] = time.process_time() - started
        found["peak_mb"] = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()


def assert_design_kept(client: TestClient, robot_id: str, design: dict[str, Any], measurement: str) -> None:
    """A design just made reads back with its references and measurement, and is the robot's one listed design."""
    stored = client.get(f"/v1/pose-designs/{design['id']}").json()
    assert stored["references"] == design["references"] and stored["measurement"] == measurement
    listed = client.get(f"/v1/robots/{robot_id}/pose-designs").json()
    assert [(d["id"], d["measurement"]) for d in listed] == [(design["id"], measurement)]


def posted_ur5(client: TestClient, name: str) -> str:
    """A UR5-like robot named `name` created through the API: its id."""
    made = client.post("/v1/robots", json={"name": name, "structure": ur5_like_document()})
    assert made.status_code == 201, made.text
    return str(made.json()["id"])


def ur5_truth(seed: int) -> np.ndarray:
    """A true UR5-like arm: every parameter but the base's (the tracker's frame, here the nominal) off its nominal
    by a normal draw of 0.2 its scale."""
    table = UR5.parameters
    truth = table.nominal.copy()
    rng = np.random.default_rng(seed)
    truth[6:] += rng.normal(0, 0.2, truth.size - 6) * table.scales[6:]
    return truth


def calibrate_robot(client: TestClient, robot_id: str, body: dict[str, Any]) -> dict[str, Any]:
    """The robot calibrated through the API from `body` (records and options; 201): the calibration's document."""
    answer = client.post(f"/v1/robots/{robot_id}/calibrations", json=body)
    assert answer.status_code == 201, answer.text
    found: dict[str, Any] = answer.json()
    return found


def ur5_tcp_error_mm(answer: dict[str, Any], truth: np.ndarray) -> float:
    """The UR5-like arm a calibration `answer` states (its parameters in the API's units) against the `truth`: the
    TCP's RMS distance (mm) over 300 fresh poses, in the frame the records fixed (no alignment)."""
    fitted = UR5.parameters.from_boundary([float(p["value"]) for p in answer["parameters"]])
    fresh = sample_workspace(UR5, 300, seed=999)
    error = forward_kinematics(UR5, fresh, fitted).positions - forward_kinematics(UR5, fresh, truth).positions
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))


def ur5_with_truth(client: TestClient, cell: Cell) -> str:
    """A UR5-like robot with the cell's perturbed truth as its version 2 (mm and degrees, as the parameters export
    states them): what programs are compensated with in the tests."""
    robot_id = posted_ur5(client, "ur5-cell")
    export = client.get(f"/v1/robots/{robot_id}/parameters").json()
    table = cell.desc.parameters
    boundary = dict(zip(table.names, table.as_boundary(cell.truth), strict=True))
    for row in export["parameters"]:
        row["value"] = float(boundary[row["name"]])
    imported = client.post(f"/v1/robots/{robot_id}/parameter-versions", json=export)
    assert imported.status_code == 201, imported.text
    return robot_id


TableShape = tuple[frozenset[str], tuple[tuple[str, ...], ...]]
"""A table's index names and its unique constraints' columns: what a migration declares beyond the columns."""


class MigratedFile:
    """A SQLite file moved revision by revision with alembic's own commands (what `alembic upgrade <rev>` does),
    where the app's `Database.migrate` only ever goes to head: how the old schemas a migration starts from are
    made."""

    def __init__(self, path: Path) -> None:
        self.url = f"sqlite:///{path}"
        self.config = Config()
        self.config.set_main_option("script_location", str(MIGRATIONS))
        self.config.set_main_option("sqlalchemy.url", self.url)
        self.engine = create_engine(self.url)

    def upgrade(self, revision: str) -> None:
        self._move(command.upgrade, revision)

    def downgrade(self, revision: str) -> None:
        self._move(command.downgrade, revision)

    def _move(self, move: Callable[[Config, str], None], revision: str) -> None:
        with self.engine.begin() as connection:
            self.config.attributes["connection"] = connection
            move(self.config, revision)

    def tables(self) -> dict[str, TableShape]:
        """Every table (alembic's own bookkeeping left out) with its indexes and unique constraints."""
        with self.engine.connect() as connection:
            found = inspect(connection)
            return {
                name: (
                    frozenset(str(i["name"]) for i in found.get_indexes(name)),
                    tuple(tuple(u["column_names"]) for u in found.get_unique_constraints(name)),
                )
                for name in found.get_table_names()
                if name != "alembic_version"
            }


@contextmanager
def migrated_file(path: Path) -> Iterator[MigratedFile]:
    """A `MigratedFile` at `path`, its engine disposed afterwards."""
    file = MigratedFile(path)
    try:
        yield file
    finally:
        file.engine.dispose()


class InProcess(Client):
    """The client's requests sent to the test's app instead of a socket (its paths, queries, bodies and
    headers are what is under test)."""

    def __init__(self, app: TestClient) -> None:
        super().__init__("")
        self.app = app

    def request(self, method: str, path: str, **options: Any) -> Answer:
        headers = {} if options.get("if_match") is None else {"If-Match": options["if_match"]}
        query = {k: v for k, v in (options.get("query") or {}).items() if v is not None}
        body = options.get("json_body")
        answer = self.app.request(method, path, params=query, json=body, headers=headers)
        if answer.status_code >= 400:
            raise ApiError(answer.json())
        return Answer(answer.status_code, answer.headers.get("content-type", ""), answer.content)
