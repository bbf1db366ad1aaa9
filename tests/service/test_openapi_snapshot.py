"""The committed OpenAPI document is the app's, and every error class has its RFC 9457 problem."""

from __future__ import annotations

import inspect

import pytest

from models import errors as domain
from service import errors
from service.http.problems import PROBLEMS
from service.openapi_dump import SNAPSHOT, render


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_committed_openapi_matches_the_app() -> None:
    assert SNAPSHOT.read_text() == render(), "run `python -m service.openapi_dump` and commit service/openapi.json"


def test_every_domain_and_service_error_has_a_problem() -> None:
    members = inspect.getmembers(domain, inspect.isclass)
    domain_classes = [c for _, c in members if issubclass(c, domain.CalibrationError)]
    service_classes = [c for _, c in inspect.getmembers(errors, inspect.isclass) if issubclass(c, errors.ServiceError)]
    assert len(domain_classes) >= 12 and len(service_classes) >= 7
    unmapped = [c.__name__ for c in (*domain_classes, *service_classes) if c not in PROBLEMS]
    assert not unmapped, f"add these classes to service.http.problems.PROBLEMS: {unmapped}"
    assert all(400 <= PROBLEMS[c][0] < 500 for c in domain_classes), "the caller's data is never a 5xx"
    slugs = [slug for _, slug, _ in PROBLEMS.values()]
    assert len(slugs) == len(set(slugs)), "one type per class"
