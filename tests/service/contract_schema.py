"""Schemathesis' view of an app, for the contract modules (its own module: the API tests, which import
contract_check, need not import schemathesis)."""

from __future__ import annotations

import json

import schemathesis
from fastapi import FastAPI
from schemathesis.schemas import BaseSchema
from starlette.types import ASGIApp


def asgi_schema(app: ASGIApp) -> BaseSchema:
    """`app`'s document, its requests sent to `app` in-process. Read from `app.openapi()` rather than with
    `schemathesis.openapi.from_asgi`, which fetches the document through a client of its own and so runs the app's
    lifespan once more, replacing the database of the test client already running it."""
    assert isinstance(app, FastAPI), app  # a TestClient's `app`, typed as any ASGI callable
    schema = schemathesis.openapi.from_dict(json.loads(json.dumps(app.openapi())))
    schema.app = app
    return schema
