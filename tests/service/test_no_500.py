"""Each input of issue 17 that gave a 500, on SQLite and on PostgreSQL: now a 4xx that says what is wrong."""

from __future__ import annotations

import json
import logging
from collections.abc import Iterator

import pytest
from fastapi.testclient import TestClient

from models import Registry, iwr, sample_workspace
from service.http.app import create_app
from service.services import robots as robot_service
from service.settings import Settings
from tests.service.conftest import make_client
from tests.service.contract_check import ContractClient

DESC = iwr()


@pytest.fixture
def api(database_url: str, registry: Registry) -> Iterator[ContractClient]:
    with make_client(database_url, registry) as c:
        yield c


def _robot(api: ContractClient) -> str:
    return str(api.post("/v1/robots", json={"name": "cell"}).json()["id"])


def _candidates(n: int) -> list[list[float]]:
    out: list[list[float]] = (sample_workspace(DESC, n, seed=1) * DESC.joint_to_boundary).tolist()
    return out


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_design_of_every_candidate_and_of_none(api: ContractClient) -> None:
    rid = _robot(api)
    every = api.post(f"/v1/robots/{rid}/pose-designs", json={"count": 40, "candidates": _candidates(40)})
    assert every.status_code == 201, every.text  # was a 500: the exchange had no candidate left to swap in
    assert sorted(every.json()["indices"]) == list(range(40))
    sampled = api.post(f"/v1/robots/{rid}/pose-designs", json={"count": 60, "candidate_count": 60})
    assert sampled.status_code == 201, sampled.text
    none = api.post(f"/v1/robots/{rid}/pose-designs", json={"count": 30, "candidates": []})
    assert none.status_code == 422 and "candidates is empty" in none.json()["detail"]  # was a 500 (CasADi map)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize("version", [2**31, 2**63, 2**64 + 1])
def test_a_version_beyond_the_integer_columns(api: ContractClient, version: int) -> None:
    rid = _robot(api)
    r = api.get(f"/v1/robots/{rid}/parameters", params={"version": version})
    assert r.status_code == 422 and "version" in r.json()["detail"]  # was a 500 on PostgreSQL (2^31), SQLite (2^63)
    assert api.get(f"/v1/robots/{rid}/parameters", params={"version": 2**31 - 1}).status_code == 404


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(
    "path",
    [
        "/v1/robots/a%00b",
        "/v1/robots/a%00b/parameters",
        "/v1/robots/a%00b/calibrations",
        "/v1/calibrations/%00",
        "/v1/pose-designs/x%00",
        "/v1/jobs/%00",
    ],
)
def test_a_nul_character_in_an_id(api: ContractClient, path: str) -> None:
    r = api.get(path)
    assert r.status_code == 404 and r.headers["content-type"] == "application/problem+json"  # was a 500 (psycopg)


@pytest.mark.parametrize("name", ["a\x00b", "line\nforged", "\x7f"])
def test_a_control_character_in_a_name(api: ContractClient, name: str) -> None:
    r = api.post("/v1/robots", json={"name": name})
    assert r.status_code == 422 and r.json()["errors"][0]["loc"] == ["body", "name"]  # NUL was a 500 (PostgreSQL)
    assert api.post("/v1/robots", json={"name": "cellule 3 — ünïcode"}).status_code == 201


def test_an_unexpected_error_is_logged_with_the_request_id_and_answered(
    database_url: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A plain TestClient: a 500 is a bug, which the contract rightly does not declare.
    app = create_app(Settings(database_url=database_url, job_workers=0, warm_up=False, log_level="WARNING"))
    lines: list[str] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            lines.append(self.format(record))

    handler = Collect()
    handler.setFormatter(logging.getLogger("service").handlers[0].formatter)
    logger = logging.getLogger("service.http")
    logger.addHandler(handler)

    def broken(**_: object) -> None:
        raise RuntimeError("a bug")

    monkeypatch.setattr(robot_service, "get_robot", broken)
    try:
        with TestClient(app, raise_server_exceptions=True) as api:
            r = api.get("/v1/robots/some-id", headers={"X-Request-ID": "trace-me-42"})
            healthy = api.get("/healthz").status_code
    finally:
        logger.removeHandler(handler)
    assert r.status_code == 500 and r.json()["type"].endswith("internal-error")  # a response, not a reset
    assert r.headers["x-request-id"] == "trace-me-42"
    errors = [json.loads(line) for line in lines if '"unhandled error"' in line]
    assert len(errors) == 1 and errors[0]["request_id"] == "trace-me-42" and "a bug" in errors[0]["exception"]
    assert healthy == 200
