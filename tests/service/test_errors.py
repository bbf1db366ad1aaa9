"""The service's error tree: every class declares its fields, and every field reaches `.data` (the members)."""

from __future__ import annotations

import inspect
from typing import Any

import pytest

from service import errors
from service.http.problems import RESERVED, to_problem
from tests.error_trees import check_declared_fields

CLASSES = [c for _, c in inspect.getmembers(errors, inspect.isclass) if issubclass(c, errors.ServiceError)]
SAMPLE: dict[str, Any] = {
    "line": 3,
    "column": 7,
    "record": 0,
    "calibration_id": "c-1",
    "diagnoses": [{"kind": "rank", "detail": "x"}],
    "scope": "read",
    "required": "write",
    "resource": "robot",
    "id": "r-1",
    "offered": ["application/json", "text/csv"],
    "current": '"3"',
    "start_version": 1,
    "current_version": 2,
    "retry_after": 5,
    "estimated_s": 3.5,
    "estimated_bytes": 10**9,
    "limit_s": 2.0,
    "limit_bytes": 1_500_000_000,
    "use_async": False,
    "limit": 1000,
    "content_type": "text/plain",
    "job_status": "succeeded",
}


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_field_is_declared_and_appears_in_data(cls: type[errors.ServiceError]) -> None:
    check_declared_fields(cls, SAMPLE)
    assert not set(cls.fields) & RESERVED, "a field named like a reserved member would be dropped from the problem"


def test_no_class_takes_arbitrary_members() -> None:
    for cls in CLASSES:
        kinds = {p.kind for p in inspect.signature(cls.__init__).parameters.values()}
        assert inspect.Parameter.VAR_KEYWORD not in kinds, cls.__name__


def test_the_tree_in_the_docstring_names_every_class_and_its_fields() -> None:
    doc = errors.__doc__ or ""
    for cls in CLASSES:
        assert f"{cls.__name__}({', '.join(cls.fields)})" in doc, cls.__name__


def test_fields_that_do_not_apply_are_absent_not_null() -> None:
    body = to_problem(errors.Conflict("a robot with this name exists", id="r-1"))
    assert list(body) == ["type", "title", "status", "detail", "id"]
    assert errors.NotFound("no such version", resource="parameter_version").data == {"resource": "parameter_version"}
