"""Start `python -m service` in a child process on a free loopback port (tests, benchmarks, examples)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import time
import urllib.request
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent  # the repository: `python -m service` runs from there
READY_TIMEOUT_S = 90.0
"""How long a started service may take to answer /readyz."""

STORY_DEADLINE_S = "60"
"""IWR_COMPUTE_DEADLINE_SECONDS of a server that tests a story, not its deadline: a minute (the default's 5 s was passed
by a first request that built a structure on a loaded 2-core machine: a 503 that failed the story, issue 48;
the deadlines have tests of their own)."""


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_ready(base: str, process: subprocess.Popen[bytes], timeout_s: float) -> bool:
    """Poll `base`/readyz until it answers 200 (True), or the process exits or `timeout_s` passes (False)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            with urllib.request.urlopen(base + "/readyz", timeout=1) as r:
                if r.status == 200:
                    return True
        except OSError:
            pass
        if process.poll() is not None or time.monotonic() > deadline:
            return False
        time.sleep(0.2)


@contextmanager
def running_server(database_url: str, *, timeout_s: float = READY_TIMEOUT_S, **env: str) -> Iterator[str]:
    """Yields the base URL once /readyz answers; stops the server afterwards."""
    port = free_port()
    environment = {**os.environ, "DATABASE_URL": database_url, "IWR_LOG_LEVEL": "WARNING", **env}
    process = subprocess.Popen(
        [sys.executable, "-m", "service", "--host", "127.0.0.1", "--port", str(port)],
        cwd=ROOT,
        env=environment,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    url = f"http://127.0.0.1:{port}"
    try:
        if not wait_ready(url, process, timeout_s):
            raise RuntimeError(f"the service did not start (exit code {process.poll()})")
        yield url
    finally:
        process.terminate()
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


@contextmanager
def story_server(folder: Path, *, job_workers: int = 0, **env: str) -> Iterator[str]:
    """A service on a SQLite file in `folder` with one compute process, for tests that click or type through a
    story (the CLI's, the browser's): its compute deadline a minute, not the default's 5 s, so that the story and
    not the deadline (which has its own tests) is what is tested on cores other tests share. `env`: more settings."""
    with running_server(
        f"sqlite:///{folder / 'iwr.db'}",
        timeout_s=READY_TIMEOUT_S,  # by name: mypy would take a string of `env` for it
        IWR_JOB_WORKERS=str(job_workers),
        IWR_COMPUTE_PROCESSES="1",
        IWR_COMPUTE_DEADLINE_SECONDS=STORY_DEADLINE_S,
        **env,
    ) as url:
        yield url
