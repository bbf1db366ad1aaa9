"""A live server and Debian's Chromium driven by Playwright; screenshots go to build/test-artifacts/ui: of the page
of each test that fails, and of every page the tests show with IWR_UI_SCREENSHOTS=1."""

from __future__ import annotations

import functools
import os
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import httpx
import pytest

from harness.live import story_server

CHROMIUM = Path("/usr/bin/chromium")
PAGE_WAIT_MS = 60_000
"""How long a test waits for the page to show what the API answered: a wait, not a measure of speed. On a
loaded 2-core machine (CI may be busy) a calibration's report took 16-25 s and a forced re-fit over 5 s,
Playwright's default for `expect`; the tests must not depend on the machine's load."""
ARTIFACTS = Path(__file__).resolve().parents[2] / "build" / "test-artifacts" / "ui"
EVERY_PAGE = os.environ.get("IWR_UI_SCREENSHOTS") == "1"
"""Read at import, before the suite scrubs IWR_ variables. Off by default: a full-page screenshot is Chromium's
rendering and PNG encoding of the whole page, 12 of the UI tests' 74 s of Chromium CPU for 34 pictures nobody
looks at when the tests pass (measured 2026-12-07); a failing test's page is kept whatever this says."""
# Without the background-networking flags Chromium keeps trying Google's hosts, which this closed network refuses.
CHROMIUM_FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


@pytest.fixture(autouse=True)
def _api_calls_wait_as_the_page_does(monkeypatch: pytest.MonkeyPatch) -> None:
    """The tests' own calls to the API (`httpx.get(...)` beside the page) wait as long as the page's `expect`
    does, not httpx's 5 s: under `stress --cpu 4` the server's first GET /openapi.json (the document built on
    first use) took longer, and the test failed on the machine's load. A call that names its timeout keeps it."""
    for name in ("get", "post", "put", "patch", "delete"):
        monkeypatch.setattr(httpx, name, functools.partial(getattr(httpx, name), timeout=PAGE_WAIT_MS / 1000))


# Package scope, not session: Playwright's sync API holds an asyncio loop in this thread while it runs, and a
# worker that goes on to other tests (pytest-xdist hands them out in any order) needs the thread back for their
# asyncio.run. Pytest ends the fixture before the first test outside tests/ui.
@pytest.fixture(scope="package")
def browser() -> Iterator[object]:
    if not CHROMIUM.exists():
        reason = f"{CHROMIUM} is missing (Debian package chromium; `make test` installs it when run as root)"
        if os.environ.get("CI") == "true":
            pytest.fail(reason)
        pytest.skip(reason)
    sync_api = pytest.importorskip("playwright.sync_api")
    sync_api.expect.set_options(timeout=PAGE_WAIT_MS)
    with sync_api.sync_playwright() as playwright:
        launched = playwright.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_FLAGS)
        yield launched
        launched.close()


# One server for every UI test: its start (compute processes, migrations) is most of these tests' time. Its
# compute deadline is a minute, not the default's 5 s: these tests click through stories, and a forced re-fit on
# a machine whose cores other tests share took past 5 s (a 503 the page showed; the deadline has its own tests).
@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    with story_server(tmp_path_factory.mktemp("ui"), job_workers=1) as url:
        yield url


class PageProblems:
    """Console errors and failed requests of one page: a page that loads must have none."""

    def __init__(self, page: object) -> None:
        self.messages: list[str] = []
        page.on("console", lambda m: self.messages.append(m.text) if m.type == "error" else None)  # type: ignore[attr-defined]
        page.on("pageerror", lambda e: self.messages.append(str(e)))  # type: ignore[attr-defined]
        page.on("requestfailed", lambda r: self.messages.append(f"request failed: {r.url}"))  # type: ignore[attr-defined]


def screenshot(page: object, name: str, *, always: bool = False) -> Path | None:
    """The whole page as `name`.png (its path), with IWR_UI_SCREENSHOTS=1 or `always`; else nothing (None)."""
    if not (EVERY_PAGE or always):
        return None
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    path = ARTIFACTS / f"{name}.png"
    page.screenshot(path=str(path), full_page=True)  # type: ignore[attr-defined]
    return path


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(
    item: pytest.Item, call: pytest.CallInfo[None]
) -> Generator[None, pytest.TestReport, pytest.TestReport]:
    """A failing test's page, as it was when the test failed, kept as `<test>-failed.png` (the page fixtures
    yield the page or a tuple that starts with it)."""
    report = yield
    if report.when == "call" and report.failed:
        found = getattr(item, "funcargs", {}).get("page")
        page = found[0] if isinstance(found, tuple) else found
        if page is not None:
            try:
                screenshot(page, item.name.replace("/", "_"), always=True)
            except Exception as exc:  # a closed or crashed page: the failure itself is what matters
                report.sections.append(("screenshot", f"no screenshot of the failed page: {exc}"))
    return report


def watched_page(browser: Any, server: str, **options: Any) -> Iterator[Any]:
    """A page of the server's (for a `page` fixture to yield from): at its end, it fetched from no other host and
    logged no console error or failed request but the API's own 4xx answers, which these stories include."""
    page = browser.new_page(**options)
    problems = PageProblems(page)
    hosts: set[str] = set()
    page.on("request", lambda r: hosts.add(urlparse(r.url).netloc))
    yield page
    assert hosts <= {urlparse(server).netloc, ""}, f"fetched from elsewhere: {hosts}"
    assert [m for m in problems.messages if "status of 4" not in m] == []
    page.close()
