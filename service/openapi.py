"""The published OpenAPI document: FastAPI's, plus what it cannot infer.

Added: the schemas of bodies a route reads itself (the calibration campaign, JSON or CSV), the RFC 9457
problem document and the error responses of every operation, and the API-key scheme when keys are set.
"""

from __future__ import annotations

from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from pydantic import BaseModel

from service.problems import PROBLEM_JSON
from service.schemas.calibrations import CalibrationCreate
from service.schemas.jobs import JobAccepted
from service.schemas.problems import Problem

PROBLEM_RESPONSES = {
    "400": "Malformed request (e.g. a CSV body that does not follow the header)",
    "401": "Missing or wrong API key (when keys are configured)",
    "404": "Unknown id",
    "413": "Request body too large",
    "415": "Unsupported media type",
    "422": "Invalid input: what is wrong and where",
    "503": "Not ready",
}
DECLARED_PROBLEMS = {
    "409": "Conflict with the resource's state (e.g. a job that already ended)",
    "429": "The job queue is full: retry after the Retry-After header's seconds",
}
"""Problem responses of the operations that declare them (their routes list the status)."""
EXTRA_MODELS: tuple[type[BaseModel], ...] = (CalibrationCreate, JobAccepted, Problem)
"""Referenced from `openapi_extra` (the calibration route parses its body itself) or from the error responses
added below, so FastAPI does not see them all."""


def build(app: FastAPI, *, api_keys: bool) -> dict[str, Any]:
    schema = get_openapi(title=app.title, version=app.version, description=app.description, routes=app.routes)
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    for model in EXTRA_MODELS:
        extra = model.model_json_schema(ref_template="#/components/schemas/{model}")
        for name, sub in extra.pop("$defs", {}).items():
            components.setdefault(name, sub)
        components[model.__name__] = extra
    components.pop("HTTPValidationError", None)
    components.pop("ValidationError", None)
    for path, operations in schema.get("paths", {}).items():
        for operation in operations.values():
            responses = operation.setdefault("responses", {})
            declared = {k: v for k, v in DECLARED_PROBLEMS.items() if k in responses}
            for status, description in (PROBLEM_RESPONSES | declared).items():
                if status == "404" and "{" not in path:
                    continue
                responses[status] = {
                    "description": description,
                    "content": {PROBLEM_JSON: {"schema": {"$ref": "#/components/schemas/Problem"}}},
                }
    if api_keys:
        schema["components"]["securitySchemes"] = {"ApiKey": {"type": "apiKey", "in": "header", "name": "X-API-Key"}}
    return schema


def install(app: FastAPI, *, api_keys: bool) -> None:
    """Build the document once, on first request of /openapi.json."""

    def openapi() -> dict[str, Any]:
        if app.openapi_schema is None:
            app.openapi_schema = build(app, api_keys=api_keys)
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
