"""Bounded work: what one request may cost, estimated before the work starts, from measured costs.

Every limit is named once, here, with the measurement it comes from. Timings are from this 2-core machine,
shared with other builds while measured (so they are pessimistic), one request at a time, warm process,
`/tmp` measurement script of the hardening branch (one operation per fresh process, peak RSS by getrusage):

| operation                              | measured                                   | per unit           |
|----------------------------------------|--------------------------------------------|--------------------|
| identification, N full poses           | 500: 0.21 s; 2 000: 0.54 s; 8 000: 2.9 s   | 0.36 ms, 36 KB     |
|                                        | (issue: 100 000 took 47 s and 4.3 GB)      |                    |
| inverse kinematics, N targets          | 200: 0.30 s; 1 000: 0.85 s; 3 000: 2.9 s   | 0.95 ms, 34 KB     |
|                                        | (issue: 100 000 passed 100 s and 4.9 GB)   |                    |
| pose design D, K = 30 of M sampled     | 500: 1.7 s; 2 000: 4.6 s; 5 000: 17 s      | superlinear in M   |
|                                        | peak +104 / +200 / +289 MB                 |                    |
| pose design D, K = 300 of M = 2 000    | 16 s, +827 MB                              | K^0.55, K·M bytes  |

Synchronous requests run only up to `SYNC_BUDGET_S` of estimated work; larger calibrations and designs are
refused with a 422 that says to send them with `?async=true`, and no job may exceed `JOB_MAX_S` or
`JOB_MEMORY_BYTES`. Inverse kinematics and error analysis have no job form, so their cap is the synchronous
budget.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Awaitable, Callable
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, TypeVar

import anyio
from starlette.types import ASGIApp, Receive, Scope, Send

from models.engine.cancellation import DEADLINE, CancellationToken, Cancelled
from optimal_design.criteria import Criterion, cost_factor
from service.compute.pool import ComputePool, Task
from service.errors import ClientGone, Overloaded, WorkTooLarge

T = TypeVar("T")

SYNC_BUDGET_S = 2.0
"""The default of `Settings.sync_budget_seconds`: estimated seconds of work a synchronous request may ask for
(the issue's ~2 s); above it, a job. The constants below derived from it describe the default budget."""
JOB_MAX_S = 600.0
"""The hard cap of any job's estimated time: ten minutes of one core."""
JOB_MEMORY_BYTES = 1_500_000_000
"""The hard cap of any one computation's estimated memory: with 2 job workers and 2 synchronous computations
(CORES) at most four run at once, ~6 GB in all, a quarter of this machine's 23 GB."""

CALIBRATION_S_PER_RECORD = 0.36e-3
CALIBRATION_BYTES_PER_RECORD = 40_000  # 36 KB measured (8 000 poses: +289 MB), rounded up
IK_S_PER_TARGET = 0.95e-3
IK_BYTES_PER_TARGET = 40_000  # 34 KB measured (3 000 targets: +103 MB); the 100 000 of the issue reached 4.9 GB
IK_MAX_TARGETS = int(SYNC_BUDGET_S / IK_S_PER_TARGET)
"""2 105: what the budget allows, since inverse kinematics cannot run as a job."""

# Pose design, calibrated on the library's walls after the dspeed branch (K = 30, medians of seeds 1-3 in three
# runs of one warm process on the shared 2-core machine, load average 2.5-3.1; /tmp measurement script, numbers in
# docs/pose-design.md): D at M = 500 / 2 000 / 20 000 took 0.094-0.117 / 0.211-0.285 / 1.90-2.19 s, linear in M
# (0.064 s + 1.06e-4 s a candidate through the slowest run's M = 500 and M = 20 000); taken 1.5x up, so an
# estimate errs on the side of a job (through the API at load ~5 D took 0.45 s of service time at M = 2 000 and
# 3.2 s at M = 20 000). The other criteria are multiples of D: their cost_factor, from the same runs. The
# calibration before (5.85 s at M = 20 000, 0.63 s at M = 2 000) dated from before issue 30 and was 2-3x D's time.
DESIGN_FIXED_S = 0.09  # information blocks, baselines and report at small M
DESIGN_S_PER_CANDIDATE = 1.55e-4  # 1.06e-4 s a candidate, x1.5 (rounded up)
DESIGN_K_EXPONENT = 0.55
"""K = 30 -> 300 at M = 2 000 took 4.6 s -> 16 s (x3.5 for x10) when measured, before issue 30. Now (one design
each, load ~5) D grows x1-1.8 for x10, A x7, I x4.5, E x9 and condition x13: one exponent for all errs up for D and
down for the others at large K (left as it was: those designs are jobs beyond K ~ 45 anyway)."""
DESIGN_BASE_BYTES = 150_000_000  # peak 252 MB at M = 2 000 and 671 MB at M = 20 000 (K = 30, after the speed-up)
DESIGN_BYTES_PER_CANDIDATE = 30_000  # (671 - 252) MB / 18 000 candidates = 23 KB, rounded up
DESIGN_BYTES_PER_PAIR = 400  # per chosen pose and candidate: the exchange's swap tables
ERROR_ANALYSIS_FIXED_S = 0.2  # sampling the poses and the nominal FK
ERROR_ANALYSIS_S_PER_EVALUATION = 100e-6
"""poses × draws, each three perturbed FK solves: measured 8 000 in 0.97 s, 20 000 in 1.73 s, 40 000 in 4.0 s
(one process, the models warm, this machine under the others' load); so 18 000 evaluations fill the budget
(the schema's former cap, 40 000, was twice the budget)."""
ERROR_ANALYSIS_BYTES_PER_EVALUATION = 1_000  # 48 stored numbers (~400 B) and working arrays: +11 MB at 40 000
FORWARD_S_PER_POSE = 34e-6  # README's service table: 1 000 joint vectors in one request, 34 ms

# ------------------------------------------------------------------ what parsing a body may cost, bounded before it
# CSV bodies and files (campaigns, parameter imports) are bounded in their raw bytes before any parser sees them
# (`service.http.guards.table_shape`: C-speed counts, 0.1-0.2 s for 20 MB, in the parse process over 1 MB); JSON bodies
# by their nesting and keys
# (`service.http.guards.too_deep`, `MAX_OBJECT_KEYS`); YAML, URDF and structure documents by their readers (text length,
# element counts and nesting, `models.formats.ur_kinematics`, `models.formats.urdf_tree`). Measured with a /tmp script
# of issue 48's
# branch, one parse per fresh process, CPU time and peak RSS (getrusage), this 2-core machine shared with others:
#
# | body (10 MB unless said)                                | before                           | now (live, SQLite) |
# |--------------------------------------------------------|----------------------------------|--------------------|
# | CSV records with CR line ends (one line to `wc -l`),   | 714 000 rows parsed: 15.5 s,     | 422 work-too-large |
# |   POST …/calibrations as text/csv                      |   +896 MB, then a 422            |   0.06 s, +0 MB    |
# | the same as a multipart `records` file                 | 17.3 s, +350 MB, on the loop     | 422, 0.04 s, +0 MB |
# | a header and one line of 5 M fields                    | 400 after parsing, 0.22 s, +84 MB| 422, 0.25 s, +9 MB |
# | a header of 20 000 columns and one row (220 kB)        | 400 after parsing, 0.23 s        | 422, 0.01 s        |
# | 300 000 parameter rows, …/parameter-versions (8 MB)    | parsed on the loop: 1.3 s, +265 MB| 422, 0.08 s, +0 MB |
# | one cell of 10 MB (no line break)                      | 400, the csv module's field limit| the same, 0.39 s   |
#
# "now" with the counts on the event loop; moved to the parse process for bodies over 1 MB, the first row is 0.27 s
# and +36 MB at load 6-8 (the body's copy), the second 0.26 s and +41 MB.
# Valid tables cost, parsed (CPU, peak RSS): 37 500 campaign records x 17 columns (6 MB, the most any job takes)
# 0.73 s, +96 MB; 60 000 x 17 (1 M cells) 1.26 s, +153 MB; 4 000 lines x 250 unknown columns 0.26 s, +86 MB.
TABLE_CELLS_MAX = 1_000_000
"""Cells of a CSV body (or all the files of a multipart one), counted as lines plus the most frequent delimiter's
occurrences (`,`, `;` or tab: an upper count whichever the sniffer picks). Measured per cell: ~1.2 µs and ~150 bytes
for campaign columns read as numbers (60 000 rows x 17: 1.26 s, +153 MB), ~0.3 µs and ~90 bytes for columns
ignored; so the bound keeps a parse under ~1.3 s and ~160 MB. The largest campaign any job may take (37 500
records, `JOB_MEMORY_BYTES`) with 26 columns fits."""
TABLE_FIELDS_MAX = 256
"""Fields on one line of a CSV (its delimiters, counted in the raw line, plus one). Instrument exports have tens of
columns; a header of 20 000 columns took 0.23 s to name its columns, 100 000 about 1 s (each name normalised)."""
TABLE_TOKEN_MAX = 131_072
"""The longest cell: the csv module's own field limit (`csv.field_size_limit()`), refused by the reader with the
line (a 10 MB cell: 400 in 0.06 s)."""


CORES = os.cpu_count() or 1
SYNC_COMPUTE_SLOTS = CORES
"""Synchronous computations at once: each holds a core, in its own compute process (service.compute.pool)."""
SYNC_QUEUE = CORES
"""Requests that may wait for a slot; beyond them, 503 at once."""
DEADLINE_PER_BUDGET = 2.5
COMPUTE_DEADLINE_S = DEADLINE_PER_BUDGET * SYNC_BUDGET_S
"""A synchronous computation still running after this (2.5x the budget its estimate fits in: the server is
overloaded) is stopped where the solver allows it (models.engine.cancellation) and answered 503 with Retry-After, so a
synchronous request answers within QUEUE_WAIT_S + COMPUTE_DEADLINE_S (measured before: a 1 s inverse kinematics
took 26 s on the shared 2-core machine)."""
QUEUE_WAIT_S = SYNC_BUDGET_S
"""A waiting request gives up after one budget (so it answers within ~2 budgets either way)."""
RETRY_AFTER_S = math.ceil(SYNC_BUDGET_S)
GIL_SWITCH_INTERVAL_S = 0.001
"""How often a thread holding the GIL hands it over (Python's default: 5 ms). The event loop competes for the
GIL with every computation's thread; each /healthz needs several turns of the loop, so under load its latency
is a multiple of this interval (`python -m service` sets it)."""


@dataclass(frozen=True)
class Estimate:
    what: str
    seconds: float
    bytes: int


def admit(estimate: Estimate, *, run_async: bool, can_run_async: bool = True, budget_s: float = SYNC_BUDGET_S) -> None:
    """Refuse work over the synchronous budget `budget_s` (the application's `sync_budget_seconds`) unless it
    runs as a job, or over the hard cap of any job."""
    if estimate.seconds > JOB_MAX_S or estimate.bytes > JOB_MEMORY_BYTES:
        raise WorkTooLarge(
            f"{estimate.what} is estimated at {estimate.seconds:.0f} s and {estimate.bytes / 1e9:.1f} GB, over the "
            f"cap of any job ({JOB_MAX_S:.0f} s, {JOB_MEMORY_BYTES / 1e9:.1f} GB): split it",
            estimated_s=round(estimate.seconds, 3),
            estimated_bytes=estimate.bytes,
            limit_s=JOB_MAX_S,
            limit_bytes=JOB_MEMORY_BYTES,
        )
    if not run_async and estimate.seconds > budget_s:
        advice = "send it with ?async=true (a job)" if can_run_async else "send fewer at a time"
        raise WorkTooLarge(
            f"{estimate.what} is estimated at {estimate.seconds:.1f} s, over the {budget_s:g} s budget of a "
            f"synchronous request: {advice}",
            estimated_s=round(estimate.seconds, 3),
            limit_s=budget_s,
            use_async=can_run_async,
        )


def calibration(records: int) -> Estimate:
    return Estimate(
        f"a calibration of {records} measurements",
        records * CALIBRATION_S_PER_RECORD,
        records * CALIBRATION_BYTES_PER_RECORD,
    )


def inverse_kinematics(targets: int) -> Estimate:
    seconds, memory = targets * IK_S_PER_TARGET, targets * IK_BYTES_PER_TARGET
    return Estimate(f"inverse kinematics of {targets} targets", seconds, memory)


VALIDATION_S_PER_EVALUATION = 100e-6
"""A record compared with one parameter version: measured 57 µs of CPU each, the body's validation included
(30 000 tracker records, one version: 1.78 s of CPU, 4.9 s of wall at load ~5; 10 000: 0.65 s), taken up towards
the loaded wall time. So 20 000 evaluations fill the budget; 100 000 records (the schema's cap) × 50 versions were
5 million, ~5 minutes, admitted before issue 48 until the compute deadline stopped them."""
VALIDATION_BYTES_PER_RECORD = 6_000  # +168 MB at 30 000 records (5.6 KB), rounded up


def validation(evaluations: int, records: int | None = None) -> Estimate:
    """`evaluations`: records × versions; memory grows with the records (the versions are compared in turn)."""
    held = evaluations if records is None else records
    return Estimate(
        f"a validation of {evaluations} record-version comparisons",
        evaluations * VALIDATION_S_PER_EVALUATION,
        held * VALIDATION_BYTES_PER_RECORD,
    )


CHECK_S_PER_RECORD = 1e-3
"""A quick check's record, its reading included: 200 pose records against the IWR's tolerances took 0.19-0.20 s
of wall, 50 took 0.05 s (warm, one request at a time, this machine at load ~6). A check takes at most 200
records (`schemas.checks.MAX_CHECK_RECORDS`, 0.2 s); the estimate matters for a file of many more lines, refused
from its line count before it is read (2 000 lines fill the budget) rather than parsed only to be refused."""
CHECK_BYTES_PER_RECORD = VALIDATION_BYTES_PER_RECORD  # the records held as a validation holds them


def quick_check(records: int) -> Estimate:
    return Estimate(
        f"a quick check of {records} measurements", records * CHECK_S_PER_RECORD, records * CHECK_BYTES_PER_RECORD
    )


PROGRAM_S_PER_TARGET = 2.0e-4
"""Compensating and rewriting one target once it is read: 10 000 URScript targets took 1.06 s of CPU (0.87 s
compensating, 0.19 s rewriting) at load 2 to 3 on the 2-core machine (benchmarks/bench_programs.py); doubled
for load. Targets Newton cannot solve from the program's configuration go to the general inverse kinematics
(0.3 s each) only until `PROGRAM_SOLVE_S`."""
PROGRAM_S_PER_BYTE = 1.3e-6
"""Reading a program costs by its text, not by its targets: measured (CPU, load 9) 0.5 µs a byte for a
Polyscope-style script, 0.85 for a RAPID module, 0.95 for a KRL .dat, and 1.1 to 1.3 µs a byte for a dense
one-line text of numbers and operators with no target (the worst: one token every two bytes)."""
PROGRAM_BYTES_PER_BYTE = 350
"""Memory while reading: 320 bytes per byte of a dense one-line text (its tokens), 90 to 120 for real programs."""
PROGRAM_BYTES_PER_TARGET = 2 * IK_BYTES_PER_TARGET  # two inverse-kinematics batches
PROGRAM_SOLVE_S = 1.5 * SYNC_BUDGET_S
"""Past this, a program's targets that need the general inverse kinematics are listed, not solved: the answer
comes before the compute deadline (2.5x the budget), never a 503 for an ordinary file."""


def program_compensation(targets: int, size: int = 0) -> Estimate:
    """A program of `size` bytes holding up to `targets` targets: reading by its bytes, compensating by targets."""
    return Estimate(
        f"a program of {size} bytes and up to {targets} targets",
        size * PROGRAM_S_PER_BYTE + targets * PROGRAM_S_PER_TARGET,
        size * PROGRAM_BYTES_PER_BYTE + targets * PROGRAM_BYTES_PER_TARGET,
    )


def pose_design(candidates: int, count: int, fixed: int, criterion: str, *, bound_seconds: float = 0.0) -> Estimate:
    """`bound_seconds` of branch and bound come on top (D, A and I spend them all unless the tree closes)."""
    m = candidates + fixed
    seconds = DESIGN_FIXED_S + DESIGN_S_PER_CANDIDATE * m
    seconds *= cost_factor(criterion)
    seconds *= max(1.0, count / 30) ** DESIGN_K_EXPONENT  # exchange and greedy grow with K (base: K = 30)
    seconds += bound_seconds
    memory = DESIGN_BASE_BYTES + DESIGN_BYTES_PER_CANDIDATE * m + DESIGN_BYTES_PER_PAIR * count * m
    return Estimate(f"a pose design of {count} among {candidates} candidates ({criterion})", seconds, memory)


def pose_design_at_least(candidates: int) -> Estimate:
    """The least any design among `candidates` given candidates can cost (one pose, no fixed poses, the cheapest
    criterion, no branch and bound; a target design costs more): what its body's bytes tell before parsing. Over
    the budget or the cap, the exact estimate after parsing would be too."""
    cheapest = min((c.value for c in Criterion), key=cost_factor)
    least = pose_design(candidates, 1, 0, cheapest)
    return Estimate(f"a pose design among {candidates} candidates", least.seconds, least.bytes)


TARGET_DESIGNS = 5.0
"""Target mode designs several K (D and I, probed then bisected): measured 5.6-7.1 s at M = 2 000 against 1.2 s
for one K = 30 I design (optimal_design's benchmark), about five designs' worth."""


def target_design(candidates: int, fixed: int) -> Estimate:
    one = pose_design(candidates, 30, fixed, "I")
    return Estimate(
        f"a pose design for a target accuracy among {candidates} candidates",
        one.seconds * TARGET_DESIGNS,
        one.bytes,
    )


def error_analysis(poses: int, draws: int) -> Estimate:
    evaluations = poses * draws
    return Estimate(
        f"an error analysis of {poses} poses × {draws} draws",
        ERROR_ANALYSIS_FIXED_S + evaluations * ERROR_ANALYSIS_S_PER_EVALUATION,
        evaluations * ERROR_ANALYSIS_BYTES_PER_EVALUATION,
    )


def forward_kinematics(poses: int) -> Estimate:
    return Estimate(f"forward kinematics of {poses} joint vectors", poses * FORWARD_S_PER_POSE, poses * 5_000)


# ------------------------------------------------------------------ concurrency of synchronous compute
class ComputeGate:
    """At most `slots` synchronous computations at once, `queue` more waiting up to `wait_s`; beyond, 503.

    A plain counter under a lock rather than an asyncio semaphore: the tests drive one app from several event
    loops (TestClient, schemathesis), and a counter belongs to none of them."""

    def __init__(self, slots: int, queue: int, wait_s: float, deadline_s: float | None = COMPUTE_DEADLINE_S) -> None:
        self.slots, self.queue, self.wait_s, self.deadline_s = slots, queue, wait_s, deadline_s
        self.running = self.waiting = 0
        self.lock = threading.Lock()

    def _try_enter(self) -> bool:
        with self.lock:
            if self.running < self.slots:
                self.running += 1
                return True
            return False

    async def run(self, work: Callable[[CancellationToken], Awaitable[T]], receive: Receive | None = None) -> T:
        """`work(token)` within a slot; `token` is set when the client disconnects (read from `receive`, which
        after the body reports only that: `ClientGone`) or after `deadline_s` (503 `Overloaded`)."""
        await self._enter()
        try:
            if receive is not None and await _gone(receive):  # it hung up while it waited: nobody reads it
                raise ClientGone("the client disconnected before its computation started")
            return await self._within_slot(work, receive)
        finally:
            with self.lock:
                self.running -= 1

    async def _enter(self) -> None:
        if self._try_enter():
            return
        with self.lock:
            if self.waiting >= self.queue:
                raise Overloaded(self._busy(), retry_after=RETRY_AFTER_S)
            self.waiting += 1
        try:
            deadline = time.monotonic() + self.wait_s
            while not self._try_enter():
                if time.monotonic() > deadline:
                    raise Overloaded(self._busy(), retry_after=RETRY_AFTER_S)
                await anyio.sleep(0.01)
        finally:
            with self.lock:
                self.waiting -= 1

    async def _within_slot(self, work: Callable[[CancellationToken], Awaitable[T]], receive: Receive | None) -> T:
        token = CancellationToken()
        result: list[T] = []
        failed: list[Exception] = []
        late = anyio.Event()
        async with anyio.create_task_group() as tg:
            if receive is not None:
                tg.start_soon(_watch, receive, token)
            if self.deadline_s is not None:
                tg.start_soon(_deadline, token, self.deadline_s, late)
            try:
                result.append(await work(token))
            except Exception as exc:  # raised below, outside the group (which would wrap it in a group)
                failed.append(exc)
            finally:
                tg.cancel_scope.cancel()
        if not failed:
            return result[0]
        if isinstance(failed[0], Cancelled) and late.is_set():
            raise Overloaded(
                f"the computation did not finish within {self.deadline_s:g} s (the server is overloaded) and was "
                f"stopped; retry in {RETRY_AFTER_S} s",
                retry_after=RETRY_AFTER_S,
            ) from None
        if isinstance(failed[0], Cancelled):
            raise ClientGone("the client disconnected; its computation was stopped") from None
        raise failed[0]

    def _busy(self) -> str:
        return f"all {self.slots} compute slots are busy and {self.queue} requests wait; retry in {RETRY_AFTER_S} s"


async def _gone(receive: Receive) -> bool:
    with anyio.move_on_after(0.001):
        message = await receive()
        return bool(message.get("type") == "http.disconnect")
    return False


async def _watch(receive: Receive, token: CancellationToken) -> None:
    """Sets `token` when the client disconnects (cancelled with the computation's end)."""
    while True:
        message = await receive()
        if message.get("type") == "http.disconnect":
            token.cancel()
            return


async def _deadline(token: CancellationToken, seconds: float, late: anyio.Event) -> None:
    await anyio.sleep(seconds)
    late.set()
    token.cancel(DEADLINE)  # a computation paying its structure's first build runs on (models.engine.cancellation)


_current: ContextVar[tuple[ComputeGate, Receive, Scope] | None] = ContextVar("compute_gate", default=None)


class Admission:
    """Puts the app's gate and the request's `receive` where `deps.compute` finds them (innermost middleware,
    so `receive` is the one the route read its body from: after the body, it only reports a disconnect)."""

    def __init__(self, app: ASGIApp, gate: ComputeGate) -> None:
        self.app, self.gate = app, gate

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        token = _current.set((self.gate, receive, scope))
        try:
            await self.app(scope, receive, send)
        finally:
            _current.reset(token)


async def run_gated(task: Task) -> Any:
    """Run a computation within the app's gate, in its compute pool (service.compute.pool); outside a request (a
    script), just in a thread (the task's `inject` then finds nothing)."""
    current = _current.get()
    if current is None:
        return await anyio.to_thread.run_sync(lambda: task.fn(**task.kwargs))
    gate, receive, scope = current
    pool: ComputePool = scope["app"].state.compute
    if any(name == b"idempotency-key" for name, _ in scope.get("headers", [])):
        # A client that sends an Idempotency-Key retries after a timeout: the computation runs to its end so that
        # the retry replays its answer (service.http.idempotency) instead of computing again. The deadline still holds.
        return await gate.run(lambda token: pool.run(task, token), None)
    return await gate.run(lambda token: pool.run(task, token), receive)


CELL_OBSTACLES_MAX = 200
"""Obstacles in one cell: a cell's table, fixtures, guards and fences are tens; each is tested against every link
shape of every candidate a design or a check weighs (the pre-pass keeps most pairs from the library)."""
CELL_MESH_FACES_MAX = 20_000
"""Triangles over all of a cell's meshes: the library builds each mesh's bounding-volume tree at every check
(about 1 µs a triangle), and a fixture's envelope needs hundreds, not a CAD model's millions."""
CELL_LINK_SHAPES_MAX = 20
"""Shapes one link's override may give (a link is a few boxes or cylinders)."""
CELL_CHECK_POSES_MAX = 10_000
"""Joint vectors one `POST …/cell/check` takes: 10 000 are ~2 s by `CELL_CHECK_S_PER_POSE`."""
CELL_CHECK_S_PER_POSE = 2.0e-4
"""One candidate through `models.cell.check_poses`: measured 20 µs (a 60° reflector cone that refuses most poses
first) to 82 µs (a cone that sees every pose, so each reaches the collision tests) on the UR5-like arm in a cell
of a table and a fixture; x2.5 for meshes and load."""
CELL_CHECK_BYTES_PER_POSE = 20_000  # 16 frames of 4x4 doubles, the placed shapes and their spheres, rounded up


def cell_check(poses: int) -> Estimate:
    return Estimate(f"a cell check of {poses} poses", poses * CELL_CHECK_S_PER_POSE, poses * CELL_CHECK_BYTES_PER_POSE)


CELL_SAMPLED_PER_CANDIDATE = 10
"""A design with a cell samples until `candidate_count` candidates are feasible: about 14 offered per feasible
one in the UR5-like arm's cell of a table, a fixture and a tracker with a 60° reflector cone (33 659 checked for
2 403 kept at M = 2 000), fewer with a wider cone or no tracker; more with a 30° cone, up to `MAX_CANDIDATES` in
all. Ten is the estimate's middle: a design that samples past it is stopped by the compute deadline, not by
this estimate."""
CELL_DESIGN_S_PER_CHECK = 1.0e-4
"""A candidate checked inside a design (its batch of thousands amortises the frames): measured 42 µs, the
design of 30 of 2 000 above taking 2.73 s with the cell and 1.33 s without; doubled for load."""


ADAPTIVE_START_S_PER_CANDIDATE = 0.6e-3
"""An adaptive campaign's start (the pool's information at the robot's values, the greedy first batch): 1.1 s
measured at 2 000 candidates on a loaded 2-core machine, rounded up."""


def adaptive_start(candidates: int, *, in_cell: bool) -> Estimate:
    """An adaptive campaign's start on `candidates` candidates; in a cell, with the checks that find them."""
    estimate = Estimate(
        f"an adaptive campaign's start on {candidates} candidates (candidate_count)",
        candidates * ADAPTIVE_START_S_PER_CANDIDATE,
        DESIGN_BASE_BYTES + candidates * DESIGN_BYTES_PER_CANDIDATE,
    )
    return with_cell(estimate, candidates * CELL_SAMPLED_PER_CANDIDATE) if in_cell else estimate


def with_cell(estimate: Estimate, checked: int) -> Estimate:
    """A design's estimate with the cell's check of `checked` candidates on top."""
    return Estimate(
        f"{estimate.what} in a cell ({checked} candidates checked)",
        estimate.seconds + checked * CELL_DESIGN_S_PER_CHECK,
        estimate.bytes + checked * CELL_CHECK_BYTES_PER_POSE // 10,  # checked in batches, not held together
    )


# ------------------------------------------------------------------ robots of several chains (issue 47)
TREE_BRANCHES_MAX = 16
"""Branches of one tree: a dual-arm torso on a track with two positioners is six."""
TREE_JOINTS_MAX = 60
"""Joints of one tree (a humanoid's upper body is ~30); a joint vector by name is one object of them, under the
64 keys any object of a body may have (`service.http.json_bodies`)."""
TREE_LINKS_MAX = 128
"""Serial links over all the branches: each tool's chain is compiled once per structure, its path at most this."""
TREE_KINEMATICS_MAX = 1000
"""Joint vectors one `POST …/robot-trees/{id}/kinematics` takes: each brings every tool, pair and frame."""
TREE_RECORDS_MAX = 5000
"""Records (fitted and held out) of one tree calibration."""
TREE_CALIBRATION_S_PER_ROW = 1.0e-5
"""A tree calibration's cost per residual row and parameter of the tree (the Jacobian's entries, evaluated once per
LM iteration), a record counted as 6 rows: the dual-arm torso (82 parameters) took 3.3 s for 600 position records
(load average 8 on 2 cores), 0.9-1.3 s for 48."""
TREE_CALIBRATION_BASE_S = 0.8
"""What every tree calibration pays: the accuracy prediction over 200 random joint vectors (its Jacobians for
every tool and pair) and the residuals per group: most of the 0.9 s the 48-record campaign took."""
TREE_CALIBRATION_BYTES_PER_ROW = 50_000


def tree_calibration(records: int, parameters: int) -> Estimate:
    """A tree calibration of `records` records (fitted and held out) over a tree of `parameters`."""
    rows = 6 * records
    return Estimate(
        f"a tree calibration of {records} records over {parameters} parameters",
        TREE_CALIBRATION_BASE_S + rows * parameters * TREE_CALIBRATION_S_PER_ROW,
        rows * TREE_CALIBRATION_BYTES_PER_ROW // 6 + rows * parameters * 8 * 4,
    )


TREE_KINEMATICS_S_PER_POSE = 0.6e-4
"""Per joint vector and ordered pair of tools (each tool and each tool in another's frame): 0.14 s for 1 000
joint vectors of the torso's two tools (four poses each), doubled for load."""
TREE_FRAME_S = 0.04e-3
"""Per joint vector and frame drawn: 1.1 s more for the torso's 1 000 joint vectors with its 31 frames."""


def tree_kinematics(poses: int, tools: int, frames: int) -> Estimate:
    seconds = poses * (tools * tools * TREE_KINEMATICS_S_PER_POSE + frames * TREE_FRAME_S)
    return Estimate(
        f"the kinematics of {poses} joint vectors of a tree", seconds, poses * (tools * tools + frames) * 2_000
    )


TREE_DESIGN_COUNT_MAX = 2000
TREE_DESIGN_KINDS_MAX = 32
"""Kinds of record one tree design weighs (a tool's position or pose, in the instrument's or another tool's frame)."""
TREE_DESIGN_CANDIDATES_MAX = 5000
"""Joint vectors one tree design is given or draws."""
TREE_DESIGN_BASE_S = 0.3
"""What every tree design pays: the task's Jacobians over 200 joint vectors of every tool and pair, the random
baseline's 20 draws, the predicted accuracies."""
TREE_DESIGN_S_PER_ENTRY = 1.0e-5
"""Per candidate record's Jacobian entry (rows × the tree's parameters), for D: measured (CPU, load ~8 on 2 cores)
0.26-0.5 s for 400-2 000 position records of the arm and positioner (56 parameters), 4.5 s for 2 000 of the
torso (82), 6.5 s for 2 000 of its pose records; other criteria by their `cost_factor`, K beyond 30 as a pose
design's."""
TREE_DESIGN_BYTES_PER_ENTRY = 200


def tree_design(records: int, rows: int, parameters: int, count: int, criterion: str) -> Estimate:
    """A tree design choosing `count` of `records` candidate records of up to `rows` rows each."""
    entries = records * rows * parameters
    seconds = TREE_DESIGN_S_PER_ENTRY * entries * cost_factor(criterion) * max(1.0, count / 30) ** DESIGN_K_EXPONENT
    return Estimate(
        f"a tree design of {count} among {records} candidate records ({criterion})",
        TREE_DESIGN_BASE_S + seconds,
        DESIGN_BASE_BYTES + entries * TREE_DESIGN_BYTES_PER_ENTRY + DESIGN_BYTES_PER_PAIR * count * records,
    )


TREE_TARGETS_MAX = 2000
"""Targets of one tree compensation: Newton from the program's joints, no general inverse kinematics after."""
TREE_COMPENSATION_S_PER_TARGET = 0.5e-3
"""Per target: the frame tool's and the prefix's kinematics, Newton on the tool's own branches (12 targets of the
torso's left arm: ~4 ms once its Functions are built), with room for load."""


def tree_compensation(targets: int) -> Estimate:
    return Estimate(
        f"a compensation of {targets} targets of a tree",
        targets * TREE_COMPENSATION_S_PER_TARGET,
        targets * IK_BYTES_PER_TARGET,
    )
