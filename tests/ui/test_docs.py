"""/docs renders in a real browser with nothing fetched from outside the service (offline plants)."""

from __future__ import annotations

from urllib.parse import urlparse

import pytest

from tests.ui.conftest import PAGE_WAIT_MS, PageProblems, screenshot

pytestmark = pytest.mark.slow


def test_api_docs_render_offline(browser: object, server: str) -> None:
    path, ready = "/docs", ".swagger-ui .opblock"
    page = browser.new_page()  # type: ignore[attr-defined]
    problems = PageProblems(page)
    hosts: set[str] = set()
    page.on("request", lambda r: hosts.add(urlparse(r.url).netloc))
    page.goto(server + path)
    page.wait_for_selector(ready, timeout=PAGE_WAIT_MS)
    screenshot(page, path.strip("/"))
    assert hosts <= {urlparse(server).netloc, ""}, f"fetched from elsewhere: {hosts}"
    assert problems.messages == []
    assert page.locator(".opblock").count() >= 10  # the operations of the contract are listed
    page.close()
