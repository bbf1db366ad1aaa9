"""What the `iwr` tests share: the command run as a user runs it (a subprocess, `python -m iwr_client`), in a
shell without the IWR_ variables, and the API's own answer read without the client under test."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

from harness.live import ROOT


def environment() -> dict[str, str]:
    """The user's shell without IWR_URL or IWR_API_KEY: each run names its service with --url."""
    return {k: v for k, v in os.environ.items() if not k.startswith("IWR_")}


def iwr(url: str, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "iwr_client", "--url", url, *args],
        cwd=ROOT,
        env=environment(),
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def api(url: str, path: str) -> Any:
    """The API's own answer, read without the client under test."""
    with urllib.request.urlopen(url + path, timeout=30) as answer:
        return json.load(answer)


class StandIn(BaseHTTPRequestHandler):
    """The handler of a stand-in for the service: its answers canned, nothing logged (the tests read what was sent
    and what came back, not a log)."""

    def answer(self, status: int, content_type: str, body: bytes) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def answer_json(self, status: int, document: object) -> None:
        """`document` as JSON, with a problem's media type for a status of 400 or more."""
        content_type = "application/json" if status < 400 else "application/problem+json"
        self.answer(status, content_type, json.dumps(document).encode())

    def log_message(self, *args: object) -> None:
        pass


@contextmanager
def serving(handler: type[BaseHTTPRequestHandler]) -> Iterator[str]:
    """`handler` answering on a free loopback port from a thread (a stand-in for the service, its answers canned):
    the base URL, the server shut down after the block."""
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    # A short poll: shutdown() waits for the loop's next poll, half a second by default, in every test's teardown.
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.02}, daemon=True).start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()
