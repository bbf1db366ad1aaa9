"""Synchronous compute off the API process: a pool of worker processes, each with its own models registry.

Why processes, not threads: the event loop competes for the GIL with every computation's thread, and IPOPT
calls back into Python at every evaluation, pydantic and json hold the GIL for a whole large body, and CasADi's
and numpy's small calls hand it back rarely. Measured with threads (benchmarks/bench_hardening.py, 2 cores):
/healthz p99 1.08 s under the mixed load. In a process, a computation can only take a core.

- `ComputePool(processes=N)`: N spawned processes (one per core by default, `IWR_COMPUTE_PROCESSES`), each
  started by `start_process`: its own engine, model cache and registry (built once by
  `service.registry.build_registry`, the API's factory), and a watch that ends it with its parent.
  `processes=0`: the same calls in threads of this process, with the app's own (tests, scripts).
- A `Task` is a module-level function and its keyword arguments (pickled to the process); `inject` names what
  the process supplies itself (`db`, `models`, `registry`): a Database, a cache or compiled Functions cannot
  travel.
- Large bodies are parsed and checked in one more process (`call`), also without the GIL the loop needs.
- The compute processes run at a lower priority (`NICE`) than the API process, whose loop must answer at once.
- Cancellation: each of the N slots has one byte of shared memory. The API process sets it when the client
  disconnects or the computation passes its deadline (service.limits); the process's `CancellationToken` reads
  it (models.cancellation), so IPOPT stops at its next iteration, a pose design or an inverse-kinematics batch
  at its next step.
- Exceptions travel as (class, args, attributes), re-raised here unchanged: the service's errors have
  keyword-only constructors that plain pickling cannot rebuild (and an unpicklable result would break the pool).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import multiprocessing
import os
import threading
import time
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from typing import Any

import anyio

from models import Registry
from models.cancellation import DEADLINE, CancellationToken, cancellable, exempt_builds
from service import logs
from service.errors import Overloaded, ParseTimeout
from service.model_cache import ModelCache
from service.parent_watch import watch_parent
from service.persistence import Database
from service.registry import build_registry
from service.settings import Settings

log = logging.getLogger("service.compute")

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

    def supplied(self) -> dict[str, Any]:
        return {"db": self.db, "models": self.models, "registry": self.registry}


_process: _Process | None = None
"""Set once per compute process by `start_process`."""


def start_process(settings: Settings, flags: Any, parent: int) -> None:
    global _process  # noqa: PLW0603  (an initializer can leave its state only in the process's module)
    watch_parent(parent)
    _lower_priority()
    started = time.perf_counter()
    registry = build_registry(settings)  # the API's own factory: the same structures warmed, once per process
    log.info("compute process %d: models built in %.2f s", os.getpid(), time.perf_counter() - started)
    db = Database(settings.database_url)
    _process = _Process(db, ModelCache(db), registry, flags)


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
    try:
        return _call(task, state.supplied(), token, request_id)
    except Exception as exc:
        if not hasattr(exc, "detail"):  # not a service or domain error: the API process logs it as a 500 too
            log.exception("compute task failed", extra={"request_id": request_id})
        return _Raised.of(exc)


class ComputePool:
    """`processes` worker processes (0: threads of this process) for the synchronous computations."""

    def __init__(self, db: Database, models: ModelCache, registry: Registry, settings: Settings, *, slots: int) -> None:
        self.settings, self.processes = settings, settings.compute_processes
        self.local = _Process(db, models, registry, None)  # what the threads use without processes
        self._context = multiprocessing.get_context("spawn")
        self.flags = self._context.Array("b", max(slots, 1), lock=False)
        self._free = list(range(max(slots, 1)))
        self._lock = threading.Lock()
        self._executor: ProcessPoolExecutor | None = None
        self._parser: ProcessPoolExecutor | None = None
        self._parsing = 0

    def _pool(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._executor is None:
                self._executor = ProcessPoolExecutor(
                    max_workers=self.processes,
                    mp_context=self._context,
                    initializer=start_process,
                    initargs=(self.settings, self.flags, os.getpid()),
                )
            return self._executor

    def _parse_pool(self) -> ProcessPoolExecutor:
        with self._lock:
            if self._parser is None:
                self._parser = ProcessPoolExecutor(
                    max_workers=PARSE_PROCESSES,
                    mp_context=self._context,
                    initializer=start_parser,
                    initargs=(os.getpid(),),
                )
            return self._parser

    async def start(self) -> None:
        """Spawn every process and wait until each has built its models (so no request pays for it)."""
        if self.processes <= 0:
            return
        pool = self._pool()
        parser = self._parse_pool()
        pids = await asyncio.gather(
            *(asyncio.wrap_future(pool.submit(_ready)) for _ in range(self.processes)),
            asyncio.wrap_future(parser.submit(_ready)),
        )
        log.info("compute processes ready: %s", sorted(set(pids)))

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
        try:
            return await asyncio.wait_for(asyncio.wrap_future(future), deadline)
        except TimeoutError:
            self._kill_parser()
            raise ParseTimeout(
                f"the body was not read within {deadline:g} s (the parse deadline) and was dropped; send less in "
                "one request (a campaign in parts, fewer targets)",
                limit_s=deadline,
            ) from None
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
        """Run `task`; when `token` is set meanwhile, the computation is told to stop (models.cancellation)."""
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
        result = await self._await(lambda pool: pool.submit(_in_process, task, slot, rid), token, slot)
        if isinstance(result, _Raised):
            raise result.rebuild()
        return result

    async def _await(
        self, submit: Callable[[ProcessPoolExecutor], Future[Any]], token: CancellationToken | None, slot: int
    ) -> Any:
        try:
            try:
                future = submit(self._pool())
            except BrokenProcessPool:
                self._replace()
                future = submit(self._pool())
        except BaseException:
            if slot >= 0:
                self._release(slot)
            raise
        if slot >= 0:
            future.add_done_callback(lambda _: self._release(slot))
        waiting = asyncio.wrap_future(future)
        try:
            while True:
                done, _ = await asyncio.wait({waiting}, timeout=CANCEL_POLL_S if token is not None else None)
                if done:
                    break
                if token is not None and token.cancelled and slot >= 0:
                    self.flags[slot] = 2 if token.reason == DEADLINE else 1
            return waiting.result()
        except BrokenProcessPool:
            # A process died (killed, out of memory): this request fails as overloaded, the next gets a new pool.
            self._replace()
            raise Overloaded("a compute process stopped; retry", retry_after=1) from None
        finally:
            if not future.done() and slot >= 0:
                self.flags[slot] = 1  # nobody waits for it any more (the request was cancelled): stop it

    def _release(self, slot: int) -> None:
        with self._lock:
            self._free.append(slot)

    def _replace(self) -> None:
        with self._lock:
            broken, self._executor = self._executor, None
        if broken is not None:
            broken.shutdown(wait=False, cancel_futures=True)

    def shutdown(self) -> None:
        with self._lock:
            pools = [self._executor, self._parser]
            self._executor = self._parser = None
        for pool in pools:
            if pool is not None:
                pool.shutdown(wait=False, cancel_futures=True)
                for process in _processes_of(pool):
                    process.terminate()


def _processes_of(pool: ProcessPoolExecutor) -> list[Any]:
    """The pool's live processes (a private attribute: the executor offers no other way to end them)."""
    return list((getattr(pool, "_processes", None) or {}).values())
