"""Answers from response models the service has just built (validated once, in `conversions`).

Routes declare their `response_model` (the contract, in the OpenAPI document) and return these, so FastAPI
does not dump, validate and serialise the same model a second time.
"""

from __future__ import annotations

import functools
from typing import Any, TypeVar

from fastapi.responses import Response
from pydantic import BaseModel, TypeAdapter

M = TypeVar("M", bound=BaseModel)


def model_json(model: BaseModel, status_code: int = 200, *, etag: str | None = None) -> Response:
    """The model as JSON; with `etag`, the ETag of what it shows (a robot's or a tree's revision)."""
    body = model.__pydantic_serializer__.to_json(model)
    return _tagged(Response(body, status_code=status_code, media_type="application/json"), etag)


def models_json(models: list[M], item: type[M], status_code: int = 200, *, etag: str | None = None) -> Response:
    """The models, each an `item`, as a JSON array; with `etag`, as `model_json`."""
    body = _list_of(item).dump_json(models)
    return _tagged(Response(body, status_code=status_code, media_type="application/json"), etag)


@functools.cache
def _list_of(item: type[BaseModel]) -> TypeAdapter[list[Any]]:
    """The adapter of a list of `item`, built once per response model (building one costs a schema build)."""
    return TypeAdapter(list[item])  # type: ignore[valid-type]  # a list of the model given at run time


def _tagged(response: Response, etag: str | None) -> Response:
    if etag is not None:
        response.headers["ETag"] = etag
    return response
