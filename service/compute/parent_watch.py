"""A helper process (compute, parse, job, build) ends with the server that started it, even after kill -9."""

from __future__ import annotations

import os
import threading
import time


def watch_parent(server: int) -> None:
    """End this process once `server` is gone: a thread polls this process's parent, which changes when the
    process is re-parented (kill -9 leaves no chance to tell the children). The parent is the server itself (a
    Celery prefork child) or the forkserver it started (`service.compute.processes`), which exits as soon as the
    server's end of its pipe closes; `server` is also polled, for a server that is gone but not yet reaped."""
    threading.Thread(target=_exit_with, args=(server, os.getppid()), name="parent-watch", daemon=True).start()


def _exit_with(server: int, parent: int) -> None:
    while os.getppid() == parent and _exists(server):
        time.sleep(0.2)
    os._exit(0)


def _exists(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except (ProcessLookupError, PermissionError):  # gone, or someone else's process under that pid
        return False
    return True
