"""Answers from response models the service has just built (validated once, in `conversions`).

Routes declare their `response_model` (the contract, in the OpenAPI document) and return these, so FastAPI
does not dump, validate and serialise the same model a second time.
"""

from __future__ import annotations

from typing import Any

from fastapi.responses import Response
from pydantic import BaseModel, TypeAdapter


def model_json(model: BaseModel, status_code: int = 200, *, etag: str | None = None) -> Response:
    """The model as JSON; with `etag`, the ETag of what it shows (a robot's or a tree's revision)."""
    body = model.__pydantic_serializer__.to_json(model)
    return _tagged(Response(body, status_code=status_code, media_type="application/json"), etag)


def models_json(
    models: list[Any], adapter: TypeAdapter[Any], status_code: int = 200, *, etag: str | None = None
) -> Response:
    return _tagged(Response(adapter.dump_json(models), status_code=status_code, media_type="application/json"), etag)


def _tagged(response: Response, etag: str | None) -> Response:
    if etag is not None:
        response.headers["ETag"] = etag
    return response
