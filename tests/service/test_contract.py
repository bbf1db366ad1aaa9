"""Property-based contract tests (schemathesis) of every operation, and the response checker they share with the
API tests. (The committed OpenAPI document and the error table: tests/service/test_openapi_snapshot.py.)"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import content_type_conformance, response_schema_conformance

from service.app import create_app
from service.settings import Settings
from tests.service.contract_check import ContractChecker

# Outside the inner loop: schemathesis builds its cases at import, ~8 s of CPU per pytest process.
pytestmark = pytest.mark.slow


_DB = Path(__import__("tempfile").mkdtemp()) / "contract.db"
APP = create_app(
    Settings(database_url=f"sqlite:///{_DB}", warm_up=False, background_builds=False, job_workers=0, log_level="ERROR")
)
schema = schemathesis.openapi.from_asgi("/openapi.json", APP)


@pytest.fixture(scope="module", autouse=True)
def running_app() -> Iterator[TestClient]:
    with TestClient(APP) as client:
        # One real robot, so that generated requests with its id get past the 404s.
        client.post("/v1/robots", json={"name": "contract"})
        yield client


# POST /v1/error-analysis is the one slow operation here: schemathesis sends requests of up to the
# budget's 18 000 poses x draws (service.limits), seconds each; tests/service/conftest.py marks that case slow.
@schema.parametrize()
@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_contract(case: schemathesis.Case[Any]) -> None:
    """Every operation: no 5xx, responses conform to their schemas."""
    case.call_and_validate(checks=[not_a_server_error, response_schema_conformance, content_type_conformance])


def test_the_response_checker_refuses_unknown_keys_and_undeclared_answers() -> None:

    checker = ContractChecker(APP.openapi())
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
