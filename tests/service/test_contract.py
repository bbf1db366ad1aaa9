"""The committed OpenAPI document, the error table, and property-based contract tests (schemathesis)."""

from __future__ import annotations

import inspect
from collections.abc import Iterator
from pathlib import Path

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, settings
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import content_type_conformance, response_schema_conformance

from models import errors as domain
from service import errors
from service.app import create_app
from service.openapi_dump import SNAPSHOT, render
from service.problems import PROBLEMS
from service.settings import Settings


def test_committed_openapi_matches_the_app() -> None:
    assert SNAPSHOT.read_text() == render(), "run `python -m service.openapi_dump` and commit service/openapi.json"


def test_every_domain_and_service_error_has_a_problem() -> None:
    members = inspect.getmembers(domain, inspect.isclass)
    domain_classes = [c for _, c in members if issubclass(c, domain.CalibrationError)]
    service_classes = [c for _, c in inspect.getmembers(errors, inspect.isclass) if issubclass(c, errors.ServiceError)]
    assert len(domain_classes) >= 12 and len(service_classes) >= 7
    unmapped = [c.__name__ for c in (*domain_classes, *service_classes) if c not in PROBLEMS]
    assert not unmapped, f"add these classes to service.problems.PROBLEMS: {unmapped}"
    assert all(400 <= PROBLEMS[c][0] < 500 for c in domain_classes), "the caller's data is never a 5xx"
    slugs = [slug for _, slug, _ in PROBLEMS.values()]
    assert len(slugs) == len(set(slugs)), "one type per class"


_DB = Path(__import__("tempfile").mkdtemp()) / "contract.db"
APP = create_app(Settings(database_url=f"sqlite:///{_DB}", warm_up=False, job_workers=0, log_level="ERROR"))
schema = schemathesis.openapi.from_asgi("/openapi.json", APP)


@pytest.fixture(scope="module", autouse=True)
def running_app() -> Iterator[TestClient]:
    with TestClient(APP) as client:
        # One real robot, so that generated requests with its id get past the 404s.
        client.post("/v1/robots", json={"name": "contract"})
        yield client


@schema.parametrize()
@settings(max_examples=12, deadline=None, suppress_health_check=list(HealthCheck))
def test_api_contract(case: schemathesis.Case) -> None:
    """Every operation: no 5xx, responses conform to their schemas."""
    case.call_and_validate(checks=[not_a_server_error, response_schema_conformance, content_type_conformance])
