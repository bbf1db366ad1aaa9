"""How the service starts its helper processes (compute lanes, the parse process, structure builds, the embedded
job pool): forked from a forkserver that imported the service once, not spawned to import it again each time.

A spawned helper paid ~1.5-2 s of CPU to import numpy, CasADi, SQLAlchemy and the service before its first task:
every compute lane and the parse process of every start, each lane replaced after a kill, each structure's
background build. The forkserver (one per process that starts helpers, started at the first) imports
`PRELOAD` once; each helper is then a fork of it, its modules already loaded, sharing their pages until
written. The forkserver holds no threads or connections, so forking it is safe where forking the API process (its
event loop, its database pool, its watchdog thread) is not.

What a spawned helper got for free and a fork of the forkserver does not: the starting process's environment
and working directory as they are now (the forkserver has them as they were when it started). `executor` hands
them over: each helper first takes the environment and directory of the process that created its pool, then runs
its own initializer. Settings read from the environment at import (`service.compute.faults`) are read
at each use instead.
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.context import ForkServerContext
from typing import Any

PRELOAD = ["service.http.app", "service.jobs.runner", "service.compute.builds", "service.compute.preload"]
"""What the forkserver imports before its first fork: the app imports every route, service and model a task can
name, and the job runner and the builds are what the other helpers run; the last builds the IWR's runtimes that
each compute lane and job-pool process would otherwise build for itself (service.compute.registry.preload)."""


def context() -> ForkServerContext:
    """The multiprocessing context of every helper process."""
    forkserver = multiprocessing.get_context("forkserver")
    forkserver.set_forkserver_preload(PRELOAD)  # read when the forkserver starts (the first helper of a process)
    return forkserver


def executor(workers: int, start: Callable[..., Any], *args: Any) -> ProcessPoolExecutor:
    """An executor of `workers` helper processes, each of which takes this process's environment and working
    directory of now, then runs `start(*args)`."""
    return ProcessPoolExecutor(
        max_workers=workers,
        mp_context=context(),
        initializer=_adopt,
        initargs=(dict(os.environ), os.getcwd(), start, args),
    )


def _adopt(environment: dict[str, str], cwd: str, start: Callable[..., Any], args: tuple[Any, ...]) -> None:
    os.environ.clear()
    os.environ.update(environment)
    os.chdir(cwd)
    start(*args)
