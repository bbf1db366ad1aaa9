"""The published OpenAPI document: FastAPI's, plus what it cannot infer.

Added: the schemas of bodies a route reads itself (the calibration campaign, JSON or CSV), the RFC 9457
problem document and the error responses of every operation, and the API-key scheme when keys are set.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from pydantic import BaseModel

from service.http.operations import Operation, job_scope
from service.http.operations import table as operation_table
from service.http.problems import PROBLEM_JSON
from service.http.security import Scope
from service.schemas.calibrations import CalibrationCreate
from service.schemas.checks import QuickCheckCreate
from service.schemas.exports import DhTablePublic
from service.schemas.jobs import JobAccepted
from service.schemas.kinematics import ForwardRequest, InverseRequest
from service.schemas.problems import Problem
from service.schemas.validations import ValidationCreate
from service.schemas.versions import ParameterVersionImport

PROBLEM_RESPONSES = {
    "400": "Malformed request (e.g. a CSV body that does not follow the header)",
    "401": "Missing or wrong API key (when keys are configured)",
    "403": "The key's scope does not cover this operation",
    "404": "Unknown id",
    "408": "The request body did not arrive in time",
    "409": "Conflict: a newer parameter version won, or the Idempotency-Key's first request is still running",
    "413": "Request body too large",
    "415": "Unsupported media type",
    "422": "Invalid input: what is wrong and where",
    "503": "Not ready",
}
OPTIONAL_PROBLEMS = ("406", "412")
POST_ONLY = frozenset({"409"})
IDEMPOTENCY_KEY = {
    "name": "Idempotency-Key",
    "in": "header",
    "required": False,
    "description": "Retries with the same key and request replay the first answer (service.http.idempotency)",
    "schema": {"type": "string", "minLength": 1, "maxLength": 200, "pattern": "^[!-~]+$"},
}
EXTRA_MODELS: tuple[type[BaseModel], ...] = (
    CalibrationCreate,
    ForwardRequest,
    InverseRequest,
    JobAccepted,
    Problem,
    ParameterVersionImport,
    DhTablePublic,
    ValidationCreate,
    QuickCheckCreate,
)
"""Referenced from `openapi_extra` (the calibration, validation, check and kinematics routes read their bodies
themselves) or from the error responses added below, so FastAPI does not see them all."""
PUBLISHED_BY_EXTRA = ("AnchorDescription", "Noise", "PlaneDescription", "PointDescription")
"""Components the calibration body published before a route's body (the pose design's) shared them: they stay
as published (FastAPI words the same model a little otherwise: no `"default": null`, bounds as floats)."""
DECLARED_PROBLEMS = {
    "409": "Conflict with the resource's state (e.g. a job that already ended)",
    "429": "The job queue is full: retry after the Retry-After header's seconds",
}
"""Problem responses of the operations that declare them (their routes list the status)."""


def _secured(operation: dict[str, Any], policy: Operation | None) -> None:
    """A /v1 operation's key: declared whether or not this instance has keys, so generated clients always send
    one; the least scope it needs, and the least its `?async=true` form (a stored job) needs."""
    operation["security"] = [{"ApiKey": []}]
    operation["x-scope"] = (Scope.admin if policy is None else policy.scope).name
    if policy is not None and policy.job is not None:
        operation["x-async-scope"] = job_scope(policy).name


def build(app: FastAPI) -> dict[str, Any]:
    schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    for model in EXTRA_MODELS:
        extra = model.model_json_schema(ref_template="#/components/schemas/{model}")
        for name, sub in extra.pop("$defs", {}).items():
            if name in PUBLISHED_BY_EXTRA:
                components[name] = sub
            else:
                components.setdefault(name, sub)
        components[model.__name__] = extra
    components.pop("HTTPValidationError", None)
    components.pop("ValidationError", None)
    policies = operation_table(app)
    for path, operations in schema.get("paths", {}).items():
        for method, operation in operations.items():
            responses = operation.setdefault("responses", {})
            declared = {k: v for k, v in DECLARED_PROBLEMS.items() if k in responses}
            for status, description in (PROBLEM_RESPONSES | declared).items():
                post_only = status in POST_ONLY and method != "post" and status not in declared
                # 404 belongs to paths with an id, and to those whose route declares it (an id in the body).
                if (status == "404" and "{" not in path and status not in responses) or post_only:
                    continue
                responses[status] = {
                    "description": description,
                    "content": {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}},
                }
            # Statuses only some operations answer (406 by content negotiation, 412 by If-Match): the route
            # declares them with a description, the problem body is added here.
            for status in OPTIONAL_PROBLEMS:
                if status in responses:
                    responses[status]["content"] = {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}}
            if path.startswith("/v1") and method == "post":
                operation.setdefault("parameters", []).append(IDEMPOTENCY_KEY)
            if path.startswith("/v1"):
                _secured(operation, policies.get((method.upper(), path)))
    schema["components"]["securitySchemes"] = {
        "ApiKey": {
            "type": "apiKey",
            "in": "header",
            "name": "X-API-Key",
            "description": "Scopes read < write < admin; each operation's `x-scope` is the least it needs, "
            "`x-async-scope` the least its `?async=true` form (a stored job) needs.",
        }
    }
    return schema


def install(app: FastAPI) -> None:
    """Build the document once, on first request of /openapi.json."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = build(app)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
