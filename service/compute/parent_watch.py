"""A helper process (compute, parse, job, build) ends with the server that started it, even after kill -9."""

from __future__ import annotations

import os
import threading
import time


def watch_parent(parent: int) -> None:
    """End this process once `parent` is gone: a thread polls the parent's pid, which changes when the process
    is re-parented (kill -9 leaves no chance to tell the children)."""
    threading.Thread(target=_exit_with, args=(parent,), name="parent-watch", daemon=True).start()


def _exit_with(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(0.2)
    os._exit(0)
