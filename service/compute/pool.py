"""Synchronous compute off the API process: a pool of worker processes, each with its own models registry.

Why processes, not threads: the event loop competes for the GIL with every computation's thread, and IPOPT
calls back into Python at every evaluation, pydantic and json hold the GIL for a whole large body, and CasADi's
and numpy's small calls hand it back rarely. Measured with threads (benchmarks/bench_hardening.py, 2 cores):
/healthz p99 1.08 s under the mixed load. In a process, a computation can only take a core.

- `ComputePool(processes=N)`: N processes (one per core by default, `IWR_COMPUTE_PROCESSES`), forks of the
  forkserver (`service.compute.processes`), each started by `start_process`: its own engine, model cache and
  registry (built once by `service.compute.registry.build_registry`, the API's factory), and a watch that ends it
  with its server. `processes=0`: the same calls in threads of this process, with the app's own (tests, scripts).
- A `Task` is a module-level function and its keyword arguments (pickled to the process); `inject` names what
  the process supplies itself (`db`, `models`, `registry`): a Database, a cache or compiled Functions cannot
  travel.
- Large bodies are parsed and checked in one more process (`call`), also without the GIL the loop needs.
- The compute processes run at a lower priority (`NICE`) than the API process, whose loop must answer at once.
- Cancellation: each of the N slots has one byte of shared memory. The API process sets it when the client
  disconnects or the computation passes its deadline (service.compute.limits); the process's `CancellationToken` reads
  it (models.engine.cancellation), so IPOPT stops at its next iteration, a pose design or an inverse-kinematics batch
  at its next step.
- Exceptions travel as (class, args, attributes), re-raised here unchanged: the service's errors have
  keyword-only constructors that plain pickling cannot rebuild (and an unpicklable result would break the pool).
- Each compute process is a *lane* of its own, a one-process executor: when one dies (killed, out of memory),
  only the computation it ran fails (503, once) and only that lane is replaced. With one executor of N
  processes, a death broke the executor and failed every computation in flight (issue 48: kill -9 of one child
  failed both).
- A ceiling while the work runs, whatever its estimate said (issue 48: a one-line program admitted at cost 0
  took 20 s and 3.4 GB in one process): a watchdog thread of the API process reads each busy lane's resident
  memory every `WATCH_S` and ends the process past `memory_bytes` above its idle size (422 work-too-large,
  naming the ceiling and the size reached); and a computation told to stop that is still running `KILL_GRACE_S`
  later, inside code with no cancellation point (a parse), has its process ended too (503): at once when its
  client left (nobody waits for it), and past its deadline only once it has also used the deadline's seconds of
  CPU, so that a machine busy with other work (a report taking 7 s of wall time for 2 s of CPU at load 9) slows a
  computation down without failing it. A structure's first build is exempt from the time kill, as from the deadline
  (models.engine.cancellation): the process publishes its builds in shared memory. The parse process has the same
  memory ceiling; its time bound is the parse deadline.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import signal
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

import anyio

from models import Registry
from models.engine.cancellation import DEADLINE, CancellationToken, cancellable, exempt_builds, on_builds
from service import logs
from service.compute import processes
from service.compute.model_cache import ModelCache
from service.compute.parent_watch import watch_parent
from service.compute.registry import build_registry
from service.errors import Overloaded, ParseTimeout, WorkTooLarge
from service.persistence import Database
from service.settings import Settings

log = logging.getLogger("service.compute.pool")

PARSE_QUEUE = 3
"""Bodies that may be in the parse process at once (one parsing, the rest waiting); beyond, 503 with Retry-After
at once, like the compute slots: under more large bodies than it parses, the server sheds them rather than
queueing them for many seconds (measured: refusals of 3.5 MB bodies waited 6-11 s behind each other)."""
PARSE_RETRY_AFTER_S = 1
PARSE_PROCESSES = 1
"""Processes that parse and check large bodies (JSON, CSV) for the event loop: one, since a body within the
limit parses in well under a second, and a refusal should not wait for a compute slot."""
NICE = 5
"""The compute processes' niceness above the API process's (see `_lower_priority`): weight 335 against 1024, so
the loop wins the core when both want it. Not 10: on this machine shared with other builds, nice 10 left a 1 s
inverse kinematics 18 s behind the others' processes."""
CANCEL_POLL_S = 0.02
"""How often a waiting request looks whether its client left (to set its slot's flag): 50 wake-ups a second per
running computation, nothing next to the computation."""
WATCH_S = 0.05
"""How often the watchdog reads the busy processes' memory: a process growing at the issue's ~170 MB/s passes
its ceiling by < 10 MB before it is ended; a read of /proc/<pid>/statm costs ~20 us."""
KILL_GRACE_S = 2.0
"""How long a computation told to stop (deadline, client gone) may take to reach its next cancellation point
before its process is ended: an IPOPT iteration or a design step takes milliseconds to ~0.3 s here, under load."""


@dataclass(frozen=True)
class Task:
    """`fn(**kwargs, **{name: the process's own object for name in inject})`; `fn` at module level."""

    fn: Callable[..., Any]
    kwargs: dict[str, Any] = field(default_factory=dict)
    inject: tuple[str, ...] = ()


@dataclass(frozen=True)
class _Raised:
    cls: type[BaseException]
    args: tuple[Any, ...]
    attributes: dict[str, Any]

    @classmethod
    def of(cls, exc: BaseException) -> _Raised:
        return cls(type(exc), exc.args, dict(vars(exc)))

    def rebuild(self) -> BaseException:
        exc = self.cls.__new__(self.cls)
        BaseException.__init__(exc, *self.args)
        vars(exc).update(self.attributes)
        return exc


@dataclass
class _Process:
    db: Database
    models: ModelCache
    registry: Registry
    flags: Any  # multiprocessing shared array of bytes, one per slot
    lanes: Any = None  # the shared array of integers the watchdog reads (`_LANE_FIELDS` per lane)
    lane: int = 0

    def supplied(self) -> dict[str, Any]:
        return {"db": self.db, "models": self.models, "registry": self.registry}


_process: _Process | None = None
"""Set once per compute process by `start_process`."""


_LANE_FIELDS = 3
"""What a compute process publishes for the watchdog, at [_LANE_FIELDS * lane + i]: i = 0 the structure builds
it started, 1 those running now, 2 the slot whose computation it runs now, plus one (0: none; a slot may wait in
the lane's queue behind another, and only the one running may be ended for what its process does)."""


def start_process(settings: Settings, flags: Any, parent: int, lanes: Any = None, lane: int = 0) -> None:
    global _process  # noqa: PLW0603  (an initializer can leave its state only in the process's module)
    watch_parent(parent)
    _lower_priority()
    if lanes is not None:

        def publish(started: int, running: int) -> None:
            lanes[_LANE_FIELDS * lane], lanes[_LANE_FIELDS * lane + 1] = started, running

        on_builds(publish)
    started = time.perf_counter()
    registry = build_registry(settings)  # the API's own factory: the same structures warmed, once per process
    log.info("compute process %d: models built in %.2f s", os.getpid(), time.perf_counter() - started)
    db = Database(settings.database_url)
    _process = _Process(db, ModelCache(db), registry, flags, lanes, lane)


def start_parser(parent: int) -> None:
    # At the API's own priority: its work is bounded by the body limit, and a refusal is due within a second.
    watch_parent(parent)


def _lower_priority() -> None:
    # Below the API process: when the cores are busy, the event loop (a /healthz, a refusal) runs first and a
    # computation waits a few milliseconds; the other way round, the loop waits a whole scheduler slice.
    with contextlib.suppress(OSError):  # not allowed here: equal priority, as before
        os.nice(NICE)


def _ready() -> int:
    return os.getpid()


def _call(task: Task, supplied: dict[str, Any], token: CancellationToken | None, request_id: str | None) -> Any:
    reset = logs.request_id.set(request_id)
    try:
        with cancellable(token):
            return task.fn(**task.kwargs, **{name: supplied[name] for name in task.inject})
    finally:
        logs.request_id.reset(reset)


_REASONS: dict[int, str | None] = {0: None, 1: "stop", 2: DEADLINE}
"""A slot's shared byte: 0 run, 1 stop (the client left, nobody waits), 2 the deadline passed."""


def _in_process(task: Task, slot: int, request_id: str | None) -> Any:
    state = _process
    if state is None:
        raise RuntimeError("a compute task outside a compute process")  # a bug here, never the client's
    token = None if slot < 0 else exempt_builds(lambda: _REASONS[state.flags[slot]])
    if state.lanes is not None:
        state.lanes[_LANE_FIELDS * state.lane + 2] = slot + 1
    try:
        return _call(task, state.supplied(), token, request_id)
    except Exception as exc:
        if not hasattr(exc, "detail"):  # not a service or domain error: the API process logs it as a 500 too
            log.exception("compute task failed", extra={"request_id": request_id})
        return _Raised.of(exc)
    finally:
        if state.lanes is not None:
            state.lanes[_LANE_FIELDS * state.lane + 2] = 0


def resident_bytes(pid: int) -> int | None:
    """The resident memory of process `pid` (None when it is gone, or where /proc is not)."""
    try:
        with open(f"/proc/{pid}/statm", "rb") as statm:
            return int(statm.read().split()[1]) * _PAGE
    except (OSError, ValueError, IndexError):
        return None


_PAGE = os.sysconf("SC_PAGE_SIZE") if hasattr(os, "sysconf") else 4096
_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


def cpu_seconds(pid: int) -> float | None:
    """The CPU time (user and system) process `pid` has used (None when it is gone, or where /proc is not)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / _TICKS  # utime, stime: fields 14 and 15 of stat(5)
    except (OSError, ValueError, IndexError):
        return None


@dataclass
class _Running:
    """One computation in a lane, as the watchdog sees it."""

    slot: int
    lane: int
    pid: int | None
    limit_rss: int | None  # the resident size at which its process is ended (None: no memory ceiling)
    builds: int  # the lane's builds started when it was submitted
    limit_on_start: bool = False
    """Its lane's idle size was not known when it was submitted (a process started for it, still importing): the
    ceiling is set above the size its process has when the watchdog first sees it running, after its start-up, so
    the imports of a fresh process do not count against the request."""
    started: float = field(default_factory=time.monotonic)
    stop_since: float | None = None  # when it was told to stop (deadline, client gone)
    stop_flag: int = 0  # 1 its client left, 2 its deadline passed (the slot's shared byte)
    cpu_start: float | None = None  # its process's CPU seconds when the watchdog first saw it running
    peak: int = 0
    killed: str | None = None  # "memory" or "time" once the watchdog ended its process


class ComputePool:
    """`processes` worker processes (0: threads of this process) for the synchronous computations, each its own
    lane (a one-process executor); slot `s` runs in lane `s % processes`. `memory_bytes`: how far a computation
    may grow its process above the process's idle size (None: no ceiling)."""

    def __init__(
        self,
        db: Database,
        models: ModelCache,
        registry: Registry,
        settings: Settings,
        *,
        slots: int,
        memory_bytes: int | None = None,
    ) -> None:
        self.settings, self.processes = settings, settings.compute_processes
        self.memory_bytes = memory_bytes
        self.local = _Process(db, models, registry, None)  # what the threads use without processes
        self._context = processes.context()
        self.flags = self._context.Array("b", max(slots, 1), lock=False)
        lanes = max(self.processes, 1)
        self._shared = self._context.Array("i", _LANE_FIELDS * lanes, lock=False)
        self._lanes: list[ProcessPoolExecutor | None] = [None] * lanes
        self._idle_rss: list[int | None] = [None] * lanes
        self._free = list(range(max(slots, 1)))
        self._running: dict[int, _Running] = {}
        self._lock = threading.Lock()
        self._parser: ProcessPoolExecutor | None = None
        self._parsing = 0
        self._stopped = threading.Event()
        self._watchdog: threading.Thread | None = None

    def _lane(self, lane: int) -> ProcessPoolExecutor:
        with self._lock:
            executor = self._lanes[lane]
            if executor is None:
                executor = self._lanes[lane] = processes.executor(
                    1, start_process, self.settings, self.flags, os.getpid(), self._shared, lane
                )
            return executor

    def _parse_pool(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._parser is None:
                self._parser = processes.executor(PARSE_PROCESSES, start_parser, os.getpid())
            return self._parser

    async def start(self) -> None:
        """Spawn every process and wait until each has built its models (so no request pays for it)."""
        if self.processes <= 0:
            return
        parser = self._parse_pool()
        pids = await asyncio.gather(
            *(asyncio.wrap_future(self._warm(lane)) for lane in range(self.processes)),
            asyncio.wrap_future(parser.submit(_ready)),
        )
        self._start_watchdog()
        log.info("compute processes ready: %s", sorted(set(pids)))

    def _warm(self, lane: int) -> Future[Any]:
        """Start lane `lane`'s process now and note its idle size once it has built its models."""
        future = self._lane(lane).submit(_ready)

        def note(done: Future[Any]) -> None:
            if not done.cancelled() and done.exception() is None:
                self._idle_rss[lane] = resident_bytes(int(done.result()))

        future.add_done_callback(note)
        return future

    def _start_watchdog(self) -> None:
        with self._lock:
            if self._watchdog is None and self.processes > 0:
                self._watchdog = threading.Thread(target=self._watch, name="compute-watchdog", daemon=True)
                self._watchdog.start()

    async def call(self, fn: Callable[..., Any], *args: Any) -> Any:
        """A short, uncancellable function of plain arguments (a body check, a parse) in the parse process, or a
        thread. Not in the compute processes: a refusal must not wait behind the computations."""
        if self.processes <= 0:
            return await anyio.to_thread.run_sync(fn, *args)
        with self._lock:
            if self._parsing >= PARSE_QUEUE:
                raise Overloaded(
                    f"{PARSE_QUEUE} large bodies are being parsed; retry in {PARSE_RETRY_AFTER_S} s",
                    retry_after=PARSE_RETRY_AFTER_S,
                )
            self._parsing += 1
        try:
            return await self._parse(fn, *args)
        finally:
            with self._lock:
                self._parsing -= 1

    async def _parse(self, fn: Callable[..., Any], *args: Any) -> Any:
        try:
            future = self._parse_pool().submit(fn, *args)
        except BrokenProcessPool:
            with self._lock:
                self._parser = None
            future = self._parse_pool().submit(fn, *args)
        deadline = self.settings.parse_deadline_seconds
        started = time.monotonic()
        waiting = asyncio.wrap_future(future)
        pids = [process.pid for process in _processes_of(self._parser)] if self._parser is not None else []
        try:
            while True:
                done, _ = await asyncio.wait({waiting}, timeout=WATCH_S)
                if done:
                    return waiting.result()
                if time.monotonic() - started > deadline:
                    self._kill_parser()
                    raise ParseTimeout(
                        f"the body was not read within {deadline:g} s (the parse deadline) and was dropped; send "
                        "less in one request (a campaign in parts, fewer targets)",
                        limit_s=deadline,
                    )
                size = max((resident_bytes(pid) or 0 for pid in pids), default=0)
                if self.memory_bytes is not None and size > self.memory_bytes:
                    self._kill_parser()
                    raise WorkTooLarge(
                        f"reading the body took {size / 1e6:.0f} MB, past the memory ceiling of one request "
                        f"({self.memory_bytes / 1e6:.0f} MB), and was stopped: send less in one request",
                        estimated_s=round(time.monotonic() - started, 3),
                        estimated_bytes=size,
                        limit_s=deadline,
                        limit_bytes=self.memory_bytes,
                    )
        except BrokenProcessPool:
            with self._lock:
                self._parser = None
            raise Overloaded("the parse process stopped; retry", retry_after=1) from None

    def _kill_parser(self) -> None:
        """End the parse process that holds a body past its deadline; the next body gets a new one. The bodies
        queued behind it fail with the broken pool and are answered 503 to retry. (ProcessPoolExecutor has no
        public way to stop a running call before Python 3.14: its processes are killed directly.)"""
        with self._lock:
            parser, self._parser = self._parser, None
        if parser is not None:
            for process in _processes_of(parser):
                process.kill()
            parser.shutdown(wait=False)

    async def run(self, task: Task, token: CancellationToken) -> Any:
        """Run `task`; when `token` is set meanwhile, the computation is told to stop (models.engine.cancellation)."""
        if self.processes <= 0:
            rid = logs.request_id.get()
            inner = exempt_builds(lambda: token.reason if token.cancelled else None)
            return await anyio.to_thread.run_sync(_call, task, self.local.supplied(), inner, rid)
        with self._lock:
            if not self._free:  # the gate admits no more than the slots; this is the pool's own guard
                raise Overloaded("every compute process is busy", retry_after=1)
            slot = self._free.pop()
        self.flags[slot] = 0
        rid = logs.request_id.get()
        result = await self._await(task, rid, token, slot)
        if isinstance(result, _Raised):
            raise result.rebuild()
        return result

    def _submit(self, task: Task, rid: str | None, slot: int) -> tuple[Future[Any], _Running]:
        lane = slot % len(self._lanes)
        try:
            executor = self._lane(lane)
            future = executor.submit(_in_process, task, slot, rid)
        except BrokenProcessPool:
            self._replace(lane, warm=False)
            executor = self._lane(lane)
            future = executor.submit(_in_process, task, slot, rid)
        pid = next((process.pid for process in _processes_of(executor)), None)
        idle = self._idle_rss[lane]
        limit = None if self.memory_bytes is None or idle is None else idle + self.memory_bytes
        on_start = self.memory_bytes is not None and idle is None
        running = _Running(slot, lane, pid, limit, self._shared[_LANE_FIELDS * lane], limit_on_start=on_start)
        with self._lock:
            self._running[slot] = running
        self._start_watchdog()
        return future, running

    async def _await(self, task: Task, rid: str | None, token: CancellationToken | None, slot: int) -> Any:
        try:
            future, running = self._submit(task, rid, slot)
        except BaseException:
            self._release(slot)
            raise
        future.add_done_callback(lambda done: self._finished(slot, done))
        waiting = asyncio.wrap_future(future)
        try:
            while True:
                done, _ = await asyncio.wait({waiting}, timeout=CANCEL_POLL_S if token is not None else None)
                if done:
                    break
                if token is not None and token.cancelled:
                    self._stop(slot, 2 if token.reason == DEADLINE else 1)
            return waiting.result()
        except BrokenProcessPool:
            raise self._lost(running) from None
        finally:
            if not future.done():
                self._stop(slot, 1)  # nobody waits for it any more (the request was cancelled): stop it

    def _stop(self, slot: int, flag: int) -> None:
        self.flags[slot] = flag
        with self._lock:
            running = self._running.get(slot)
            if running is not None and running.stop_since is None:
                running.stop_since, running.stop_flag = time.monotonic(), flag

    def _lost(self, running: _Running) -> Exception:
        """The answer for a computation whose process ended under it: why, when the watchdog ended it."""
        killed = running.killed
        if killed == "memory" and self.memory_bytes is not None:
            return WorkTooLarge(
                f"the computation grew its process by more than the memory ceiling of one request "
                f"({self.memory_bytes / 1e6:.0f} MB; it reached {running.peak / 1e6:.0f} MB resident) and was "
                "stopped: send less in one request",
                estimated_s=round(time.monotonic() - running.started, 3),
                estimated_bytes=running.peak,
                limit_s=float(self.settings.compute_deadline_seconds or 0.0),
                limit_bytes=self.memory_bytes,
            )
        if killed == "time":
            return Overloaded(
                f"the computation ran on past its deadline (more than {KILL_GRACE_S:g} s, and its deadline's seconds "
                "of CPU) without stopping and its process was ended; retry in 1 s",
                retry_after=1,
            )
        return Overloaded(
            "the compute process running this computation stopped (killed or out of memory); this computation is "
            "lost, retry",
            retry_after=1,
        )

    def _finished(self, slot: int, future: Future[Any]) -> None:
        """A computation ended (result, error or its process's death): its slot is free; a dead lane is replaced
        and started at once, so the next request does not pay for its models."""
        with self._lock:
            running = self._running.pop(slot, None)
        if running is not None and not future.cancelled() and isinstance(future.exception(), BrokenProcessPool):
            self._replace(running.lane, warm=not self._stopped.is_set())
        self._release(slot)

    def _release(self, slot: int) -> None:
        with self._lock:
            self._free.append(slot)

    def _replace(self, lane: int, *, warm: bool) -> None:
        with self._lock:
            broken, self._lanes[lane] = self._lanes[lane], None
            self._idle_rss[lane] = None
            for i in range(_LANE_FIELDS):  # the dead process's last words (a killed one never said "done")
                self._shared[_LANE_FIELDS * lane + i] = 0
        if broken is not None:
            broken.shutdown(wait=False, cancel_futures=True)
        if warm:
            with contextlib.suppress(Exception):  # shutting down meanwhile: nothing to warm
                self._warm(lane)

    # Long on purpose: one pass of the watchdog over every busy lane, its two ceilings side by side.
    def _watch(self) -> None:
        while not self._stopped.wait(WATCH_S):
            with self._lock:
                busy = [running for running in self._running.values() if running.killed is None]
            now = time.monotonic()
            for running in busy:
                base = _LANE_FIELDS * running.lane
                if running.pid is None or self._shared[base + 2] != running.slot + 1:
                    continue  # still queued behind another in its lane: its process is not yet its own
                size = resident_bytes(running.pid)
                if size is None:
                    continue
                running.peak = max(running.peak, size)
                if running.limit_on_start and self.memory_bytes is not None:
                    running.limit_rss, running.limit_on_start = size + self.memory_bytes, False
                if running.limit_rss is not None and size > running.limit_rss:
                    self._end(running, "memory", f"{size / 1e6:.0f} MB resident")
                    continue
                cpu = cpu_seconds(running.pid)
                if running.cpu_start is None:
                    running.cpu_start = cpu
                if running.stop_since is None or now - running.stop_since <= KILL_GRACE_S:
                    continue
                if self._shared[base + 1] > 0 or self._shared[base] != running.builds:
                    continue  # a structure's first build runs on, as the deadline allows it
                used = (cpu or 0.0) - (running.cpu_start or 0.0)
                deadline = self.settings.compute_deadline_seconds
                if running.stop_flag == 1 or (deadline is not None and used > deadline + KILL_GRACE_S):
                    told = now - running.stop_since
                    self._end(running, "time", f"{told:.1f} s after it was told to stop, {used:.1f} s of CPU")

    def _end(self, running: _Running, why: str, detail: str) -> None:
        if running.pid is None:
            return
        running.killed = why
        log.warning("compute process %s ended by the watchdog (%s: %s)", running.pid, why, detail)
        with contextlib.suppress(ProcessLookupError):
            os.kill(running.pid, signal.SIGKILL)

    def shutdown(self) -> None:
        self._stopped.set()
        with self._lock:
            pools = [*self._lanes, self._parser]
            self._lanes = [None] * len(self._lanes)
            self._parser = None
        for pool in pools:
            if pool is not None:
                pool.shutdown(wait=False, cancel_futures=True)
                for process in _processes_of(pool):
                    process.terminate()


def _processes_of(pool: ProcessPoolExecutor) -> list[Any]:
    """The pool's live processes (a private attribute: the executor offers no other way to end them)."""
    return list((getattr(pool, "_processes", None) or {}).values())
