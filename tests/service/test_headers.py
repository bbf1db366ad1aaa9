"""The browser-facing headers (issue 48: /ui sent no Content-Security-Policy or frame headers, and the report was
shown in an iframe without `sandbox`): the UI's policy allows no inline script, nothing may frame the service,
a report served as HTML is sandboxed and scriptless, and /docs allows exactly its own inline start-up script."""

from __future__ import annotations

import base64
import hashlib
import re
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from service.ui import STATIC
from tests.service.helpers import records


def _directives(policy: str) -> dict[str, list[str]]:
    parts = [p.split() for p in policy.split(";") if p.strip()]
    return {p[0]: p[1:] for p in parts}


def _frame_headers_hold(headers: object) -> dict[str, list[str]]:
    assert headers["x-frame-options"] == "DENY"  # type: ignore[index]
    assert headers["x-content-type-options"] == "nosniff"  # type: ignore[index]
    policy = _directives(headers["content-security-policy"])  # type: ignore[index]
    assert policy["frame-ancestors"] in (["'none'"], ["'self'"])
    return policy


def test_the_ui_runs_only_its_own_script_files(client: TestClient) -> None:
    page = client.get("/ui")
    assert page.status_code == 200 and client.get("/healthz").status_code == 200  # (one answer of the contract)
    policy = _frame_headers_hold(page.headers)
    assert policy["script-src"] == ["'self'"]  # no 'unsafe-inline', no 'unsafe-eval', no other origin
    assert policy["object-src"] == ["'none'"] and policy["base-uri"] == ["'none'"]
    # and the page itself needs nothing more: no inline script, no inline handler, in any of its files
    html = page.text
    assert not re.search(r"<script(?![^>]*\bsrc=)[^>]*>", html), "an inline <script> in index.html"
    assert not re.search(r"\son[a-z]+\s*=", html), "an inline event handler in index.html"
    for module in Path(STATIC).rglob("*.js"):
        text = module.read_text()
        assert "eval(" not in text and "new Function" not in text, module
        assert ".innerHTML" not in text, module


def test_api_answers_carry_the_headers_too(client: TestClient) -> None:
    _frame_headers_hold(client.get("/healthz").headers)
    _frame_headers_hold(client.get("/v1/robots").headers)


@pytest.mark.slow  # ~2 s: a calibration and its report: outside the inner loop (make test-fast)
def test_the_report_is_a_sandboxed_document_and_its_iframe_is_sandboxed(client: TestClient, robot_id: str) -> None:
    desc = iwr()
    sim = perturbed_robot(desc, seed=101)
    recs = records(desc, sim, sample_workspace(desc, 30, seed=102), seed=103)
    calibration = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs}).json()
    page = client.get(f"/v1/calibrations/{calibration['id']}/report", headers={"Accept": "text/html"})
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    policy = _frame_headers_hold(page.headers)
    assert "sandbox" in policy and policy["sandbox"] == []  # a unique origin, no script, no forms
    assert policy["default-src"] == ["'none'"] and "script-src" not in policy  # so no script from anywhere
    assert "<style>" in page.text and policy["style-src"] == ["'unsafe-inline'"]  # its own style still applies
    report_view = (Path(STATIC) / "views" / "report.js").read_text()
    frame = re.search(r'h\("iframe", \{([^}]*)\}', report_view)
    assert frame is not None and re.search(r'\bsandbox: ""', frame.group(1)), "the report's iframe is not sandboxed"


def test_the_docs_page_allows_exactly_its_own_inline_script(client: TestClient) -> None:
    page = client.get("/docs")
    assert page.status_code == 200 and client.get("/healthz").status_code == 200  # (one answer of the contract)
    policy = _frame_headers_hold(page.headers)
    inline = re.findall(r"<script>(.*?)</script>", page.text, re.DOTALL)
    assert inline, "Swagger UI's page starts itself with an inline script"
    hashes = {"'sha256-" + base64.b64encode(hashlib.sha256(s.encode()).digest()).decode() + "'" for s in inline}
    assert set(policy["script-src"]) == {"'self'", *hashes}
    assert "'unsafe-inline'" not in policy["script-src"]
