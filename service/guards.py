"""Request hygiene before any route runs: what no route can answer well by itself.

- A path with a NUL character names nothing: every id is a UUID the service made, and PostgreSQL text cannot
  even hold NUL (psycopg raises DataError, which was a 500). Answered 404 here, for every route, present and
  future, before a query is built.
"""

from __future__ import annotations

from starlette.types import ASGIApp, Receive, Scope, Send

from service import problems
from service.errors import NotFound


class RequestGuard:
    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] == "http" and "\x00" in scope.get("path", ""):
            exc = NotFound("no resource has a NUL character in its id", resource="path")
            await problems.response(problems.to_problem(exc))(scope, receive, send)
            return
        await self.app(scope, receive, send)
