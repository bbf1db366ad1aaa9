"""The web page (`/ui`) and the API docs (`/docs`), served from this package: nothing comes from a CDN.

Plant networks are offline: FastAPI's default `/docs` loads Swagger UI from jsDelivr and is blank there. The
Swagger UI 5 assets come from the `fastapi-offline` package (installed like any dependency; Swagger UI 4
cannot read OpenAPI 3.1) and are served under `/ui/docs-assets`; the page under `/ui` is this package's own static
files, talking to the public `/v1` API.
"""

from __future__ import annotations

from pathlib import Path

import fastapi_offline
from fastapi import FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

STATIC = Path(__file__).resolve().parent / "static"
DOCS_ASSETS = Path(fastapi_offline.__file__).resolve().parent / "static"


def install(app: FastAPI, *, docs: bool = True) -> None:
    """Mount the page and, when `docs`, Swagger UI with local assets (create the app with `docs_url=None,
    redoc_url=None`: ReDoc's standalone bundle still fetches its logo from cdn.redoc.ly, so it is not offered)."""
    app.mount("/ui/static", StaticFiles(directory=STATIC), name="ui-static")

    @app.get("/ui", include_in_schema=False)
    async def ui() -> FileResponse:
        return FileResponse(STATIC / "index.html", media_type="text/html")

    if not docs:
        return
    app.mount("/ui/docs-assets", StaticFiles(directory=DOCS_ASSETS), name="docs-assets")

    @app.get("/docs", include_in_schema=False)
    async def swagger() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json",
            title=f"{app.title} — API",
            swagger_js_url="/ui/docs-assets/swagger-ui-bundle.js",
            swagger_css_url="/ui/docs-assets/swagger-ui.css",
            swagger_favicon_url="/ui/docs-assets/favicon.png",
        )
