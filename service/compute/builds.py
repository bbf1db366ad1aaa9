"""A robot structure's native code, built in the background when the robot is created, with its state on the robot.

Why: the first request on a new structure used to pay its build (CasADi graphs, C code compiled by the system
compiler, identification solvers, inverse-kinematics tables: 3-8 s for a 7R arm) inside a request meant to
answer in well under a second. Now `POST /v1/robots` starts that build and answers at once; the robot's `build`
field says `building`, then `ready` (with the seconds it took and whether the code is native or runs on CasADi's
virtual machine) or `failed` (with why). A request that arrives meanwhile waits for the same build rather than
starting a second one, and its deadline does not count the wait (`models.engine.cancellation.exempt_builds`): it is
slower once, never refused for it.

Where the build runs depends on where requests compute (`Settings.compute_processes`):
- in threads of the API process (0, the embedded default of tests and scripts): the app's own registry is
  warmed in a background thread, so the artefacts are the very ones the requests use;
- in compute processes: a short-lived process of its own builds everything of the structure once and exits.
  What it leaves is the native-library cache on disk (`models.engine.native`), which every compute process (and job
  worker) then loads by hash in a fraction of a second instead of compiling. Its own process keeps the API's
  event loop free of the build's Python work (the GIL) and its memory out of the API's.

Builds run one at a time (a burst of new robots does not start a compiler per robot on a 2-core machine); a
structure is built at most once per API process, and the state is this process's: after a restart a robot's
page starts a build again, which finds the cached libraries and is ready in about a second.
"""

from __future__ import annotations

import logging
import os
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from enum import StrEnum

from models import Registry
from models.description.robot import RobotDescription
from models.engine.native import vm_only_libraries
from models.engine.runtime import structure_tag
from models.warm import warm_everything
from service.compute import processes
from service.compute.parent_watch import watch_parent

log = logging.getLogger("service.compute.builds")


MAX_PENDING = 4
"""Builds that may wait behind the running one. Beyond, a new structure is not queued (its `build` stays null
and its first request builds it): creating robots must not become a way to keep the cores compiling."""


class BuildState(StrEnum):
    BUILDING = "building"
    READY = "ready"
    FAILED = "failed"


@dataclass(frozen=True)
class BuildStatus:
    """What a robot's `build` field reports of its structure's build in this process."""

    state: BuildState
    started_at: datetime | None
    seconds: float | None = None
    """Wall time of the build; None while it runs, or for a structure built at start-up (`started_at` None)."""
    native: bool | None = None
    """True: every library compiled to native code; False: some run on CasADi's virtual machine (slower, see
    `detail`); None while building or after a failure."""
    detail: str | None = None


@dataclass(frozen=True)
class _Built:
    seconds: float
    vm: dict[str, str]
    """The structure's libraries that run on CasADi's VM, and why (`models.engine.native.VmReason`)."""


def build_structure(desc: RobotDescription, registry: Registry | None = None) -> _Built:
    """Build every artefact of `desc`'s structure into `registry` (a new one: only the disk cache is meant to
    outlive it); module-level, so a build process can run it."""
    started = time.perf_counter()
    warm_everything(registry if registry is not None else Registry(), desc)
    tag = structure_tag(desc.structure)
    vm = {name: str(reason) for name, reason in vm_only_libraries().items() if name.endswith("_" + tag)}
    return _Built(seconds=time.perf_counter() - started, vm=vm)


class StructureBuilds:
    """The background builds of one API process (see the module docstring)."""

    def __init__(self, registry: Registry, *, in_process: bool, enabled: bool = True) -> None:
        self._registry = registry
        self._in_process = in_process
        self._enabled = enabled
        """Off (`Settings.background_builds`): nothing starts here, and a structure's first request builds it."""
        self._status: dict[str, BuildStatus] = {}
        self._lock = threading.Lock()
        # One orchestrating thread: builds run one after the other, in the order robots were created.
        self._queue = ThreadPoolExecutor(max_workers=1, thread_name_prefix="structure-build")
        self._closed = False

    def status(self, desc: RobotDescription) -> BuildStatus | None:
        """The structure's build state, None if this process has not built or started to build it."""
        tag = structure_tag(desc.structure)
        with self._lock:
            found = self._status.get(tag)
        if found is not None:
            return found
        if self._warm_here(desc):  # warmed at start-up (the IWR), before any robot asked
            return BuildStatus(BuildState.READY, started_at=None, native=self._native_here(tag))
        return None

    def ensure(self, desc: RobotDescription) -> BuildStatus | None:
        """The structure's build state, starting its build if this process has none yet."""
        found = self.status(desc)
        if found is not None or not self._enabled:
            return found
        tag = structure_tag(desc.structure)
        with self._lock:
            found = self._status.get(tag)
            if found is not None:
                return found
            pending = sum(1 for status in self._status.values() if status.state == BuildState.BUILDING)
            if self._closed or pending > MAX_PENDING:
                return None
            started = BuildStatus(BuildState.BUILDING, started_at=datetime.now(UTC))
            self._status[tag] = started
        self._queue.submit(self._run, tag, desc)
        return started

    def wait(self, desc: RobotDescription, timeout: float) -> BuildStatus | None:
        """The state once the build is no longer running, or at `timeout` (for tests and scripts)."""
        deadline = time.monotonic() + timeout
        while True:
            found = self.status(desc)
            if found is None or found.state != BuildState.BUILDING or time.monotonic() > deadline:
                return found
            time.sleep(0.02)

    def shutdown(self) -> None:
        with self._lock:
            self._closed = True
        self._queue.shutdown(wait=False, cancel_futures=True)

    # ------------------------------------------------------------------ the build itself
    def _run(self, tag: str, desc: RobotDescription) -> None:
        with self._lock:
            started = self._status[tag]
        try:
            built = build_structure(desc, self._registry) if self._in_process else self._in_own_process(desc)
        except Exception as exc:
            log.warning("structure %s: background build failed: %s", tag, exc)
            done = replace(started, state=BuildState.FAILED, detail=f"the build failed: {exc}")
        else:
            detail = None
            if built.vm:
                reasons = ", ".join(f"{name}: {reason}" for name, reason in sorted(built.vm.items()))
                detail = f"runs on CasADi's virtual machine, 5-10x slower than native code ({reasons})"
            done = replace(
                started, state=BuildState.READY, seconds=round(built.seconds, 3), native=not built.vm, detail=detail
            )
            log.info("structure %s: built in the background in %.2f s", tag, built.seconds)
        with self._lock:
            self._status[tag] = done

    def _in_own_process(self, desc: RobotDescription) -> _Built:
        # With a parent watch, like the compute processes: a build never outlives its server (kill -9 included).
        with processes.executor(1, watch_parent, os.getpid()) as process:
            future: Future[_Built] = process.submit(build_structure, desc)
            return future.result()

    def _warm_here(self, desc: RobotDescription) -> bool:
        return desc in self._registry and "kinematics" in self._registry.runtime(desc).builds

    @staticmethod
    def _native_here(tag: str) -> bool:
        return not any(name.endswith("_" + tag) for name in vm_only_libraries())
