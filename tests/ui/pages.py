"""What the browser tests share beyond the live server and the browser (tests/ui/conftest.py): a robot made
through the API, the wait for a page to be drawn, and a drawn view's mapping back to mm."""

from __future__ import annotations

import re
from typing import Any

import httpx
from playwright.sync_api import expect

from models.description.examples import ur5_like_document
from tests.ui.conftest import PAGE_WAIT_MS


def posted_ur5(server: str, name: str) -> str:
    """A UR5-like robot named `name` created through the API: its id."""
    made = httpx.post(f"{server}/v1/robots", json={"name": name, "structure": ur5_like_document()}, timeout=60)
    assert made.status_code == 201, made.text
    return str(made.json()["id"])


def ready(page: Any, pattern: str) -> None:
    """Waits until the page drawn is one whose fragment matches `pattern`."""
    # An attribute wait: the page's Content-Security-Policy forbids eval, which wait_for_function uses.
    expect(page.locator("body")).to_have_attribute("data-ready", re.compile(pattern), timeout=PAGE_WAIT_MS)


def view_mapping(page: Any, view: str) -> dict[str, float]:
    """How the drawn view `view` (an SVG's id) maps its two world coordinates to the picture: its data attributes."""
    found: dict[str, float] = page.eval_on_selector(
        f"#{view}", "s => Object.fromEntries(['u0', 'v1', 'scale', 'left', 'top'].map(k => [k, Number(s.dataset[k])]))"
    )
    return found


def to_mm(m: dict[str, float], x: float, y: float) -> tuple[float, float]:
    """An SVG point back to the view's two world coordinates in mm."""
    return m["u0"] + (x - m["left"]) / m["scale"], m["v1"] - (y - m["top"]) / m["scale"]
