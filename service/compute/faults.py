"""Crash points for the fault tests (issue 31): a test that must kill a process at one precise moment — after a
job's transaction committed, before its broker message is acknowledged — sets `IWR_FAULT` to that point's name
in the process's environment; `crash_point(name)` then ends the process at once, as kill -9 would (no clean-up,
no acknowledgement, no lease release). Unset, as in every deployment, a crash point is one comparison."""

from __future__ import annotations

import os

KILLED = 137
"""The exit status of a process killed by SIGKILL (128 + 9), which is what the crash stands for."""


def crash_point(name: str) -> None:
    # Read at each point, not at import: a helper forked from the forkserver (service.compute.processes) has the
    # modules the forkserver imported, with the environment its own server gave it since.
    if name == os.environ.get("IWR_FAULT"):
        os._exit(KILLED)
