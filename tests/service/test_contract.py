"""Property-based contract tests (schemathesis) of every operation, and the response checker they share with the
API tests. (The committed OpenAPI document and the error table: tests/service/test_openapi_snapshot.py.)"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from fastapi import FastAPI
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.schemas import BaseSchema
from schemathesis.specs.openapi.checks import content_type_conformance, response_schema_conformance

from service.http.app import create_app
from service.settings import Settings
from tests.service.contract_check import ContractChecker
from tests.service.contract_schema import asgi_schema

# Outside the inner loop (~40 s of CPU). The schema is read from the app when the tests run, in the one worker that
# runs them, not at import: schemathesis builds every operation's cases while it collects them (~5 s of CPU here,
# paid by every pytest-xdist worker, each of which collects every module). The operations then run one after
# another inside `test_api_contract`, each reported as its own subtest.
pytestmark = pytest.mark.slow


def _app() -> FastAPI:
    database = Path(tempfile.mkdtemp()) / "contract.db"
    return create_app(
        Settings(
            database_url=f"sqlite:///{database}",
            warm_up=False,
            background_builds=False,
            job_workers=0,
            log_level="ERROR",
        )
    )


@pytest.fixture(scope="module")
def running_app() -> Iterator[TestClient]:
    with TestClient(_app()) as client:
        # One real robot, so that generated requests with its id get past the 404s.
        client.post("/v1/robots", json={"name": "contract"})
        yield client


@pytest.fixture(scope="module")
def contract_schema(running_app: TestClient) -> BaseSchema:
    schema = asgi_schema(running_app.app)
    schema.config.phases.coverage.enabled = BOUNDARIES
    return schema


schema = schemathesis.pytest.from_fixture("contract_schema")


BOUNDARIES = os.environ.get("IWR_CONTRACT_BOUNDARIES", "0") == "1"
"""Schemathesis' coverage phase (every schema's boundaries, valid and invalid) here too: `make fuzz`'s. It sent
~12 000 of `make test`'s ~12 500 requests here (~100 s of a worker, the suite's longest test); without it the
operations get the schema's examples and 20 random bodies each, valid and invalid (~21 s), and PostgreSQL's run in
test_contract_fuzz.py keeps the coverage phase's valid boundaries (what reaches the database's columns)."""
EXAMPLES = int(os.environ.get("IWR_CONTRACT_EXAMPLES", "20"))
"""Random bodies per operation (read at import, like the other test knobs): 20 in `make test`; `make fuzz` runs 150
with the boundaries, on SQLite here and on PostgreSQL in test_contract_fuzz.py."""


# One item runs every operation (each a subtest): the run's 300 s hang guard is for one computation, and this item
# took 11 min of wall at load ~9 (issue 48), so it gets 15 min.
# POST /v1/error-analysis is the slowest operation here: schemathesis sends requests of up to the budget's
# 18 000 poses x draws (service.compute.limits), seconds each.
# Not traced by coverage (pytest-cov's no_cover, the call only): its ~12 500 requests are Python-heavy (the
# generator, requests' adapter, the app's middleware and validation), and tracing them cost 42 s of this test's
# 113 s of CPU; the service code they reach is measured by the API tests, and the floor holds without them.
@pytest.mark.no_cover
@pytest.mark.timeout(900)
@schema.parametrize()
@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_contract(case: schemathesis.Case[Any]) -> None:
    """Every operation: no 5xx, responses conform to their schemas."""
    case.call_and_validate(checks=[not_a_server_error, response_schema_conformance, content_type_conformance])


def test_the_response_checker_refuses_unknown_keys_and_undeclared_answers() -> None:

    checker = ContractChecker(_app().openapi())
    robot = {
        "id": "r",
        "name": "n",
        "model": "iwr",
        "parameter_version": 1,
        "created_at": "2026-01-01T00:00:00Z",
        "base": {"position": [0, 0, 0], "orientation": [1, 0, 0, 0]},
        "tool": {"position": [0, 0, 0], "orientation": [1, 0, 0, 0]},
        "notes": None,
        "revision": 1,
        "structure": {
            "stages": [{"kind": "serial", "convention": "dh", "links": [{"joint": "prismatic", "range": [0, 1]}]}]
        },
        "joint_names": ["q1"],
        "joint_units": ["mm"],
        "parameter_count": 16,
    }
    checker.check("GET", "/v1/robots/r", 200, "application/json", json.dumps(robot).encode())
    with pytest.raises(AssertionError, match="unexpected"):
        checker.check("GET", "/v1/robots/r", 200, "application/json", json.dumps({**robot, "extra": 1}).encode())
    with pytest.raises(AssertionError, match="unexpected"):  # nested too: a pose with one more key
        bad = {**robot, "base": {**robot["base"], "frame": "world"}}  # type: ignore[dict-item]
        checker.check("GET", "/v1/robots/r", 200, "application/json", json.dumps(bad).encode())
    with pytest.raises(AssertionError, match="does not declare"):
        checker.check("GET", "/v1/robots/r", 201, "application/json", json.dumps(robot).encode())
    with pytest.raises(AssertionError, match="not declared"):
        checker.check("GET", "/v1/robots/r", 200, "text/csv", b"a,b\n")
    with pytest.raises(AssertionError, match="required"):
        checker.check("GET", "/v1/robots/r/parameters", 200, "application/json", b'{"version": 1}')
