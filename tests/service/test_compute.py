"""The compute pool in processes (service/compute/pool.py), driven directly: results, the process's own database,
errors that travel back intact, cancellation through shared memory, the parse lane and its bound, a dead process."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import anyio
import pytest

from models import Registry, iwr
from models.engine import cancellation
from models.engine.cancellation import CancellationToken, Cancelled
from service.compute import pool as compute
from service.compute.model_cache import ModelCache
from service.compute.pool import ComputePool, Task
from service.errors import NotFound, Overloaded, ParseTimeout, WorkTooLarge
from service.http.guards import too_many_keys
from service.persistence import Database, Repository
from service.settings import Settings

pytestmark = pytest.mark.slow  # spawns compute processes (make test-fast skips them)


def robot_names(*, db: Database) -> list[str]:
    with db.reader() as s:
        return sorted(r.name for r in Repository(s).robots(100, 0))


def missing(*, robot_id: str) -> None:
    raise NotFound(f"no robot {robot_id!r}", resource="robot", id=robot_id)


def steps_until_cancelled(*, seconds: float) -> int:
    started, steps = time.perf_counter(), 0
    while time.perf_counter() - started < seconds:
        cancellation.check()
        steps += 1
        time.sleep(0.01)
    return steps


def pid() -> int:
    return os.getpid()


def registry_of(*, registry: Registry) -> tuple[int, int]:
    """Which registry served the task (its id in its process) and the process; it builds the IWR's runtime."""
    registry.runtime(iwr())
    return id(registry), os.getpid()


def settings(db: Database, processes: int) -> Settings:
    return Settings(database_url=db.url, compute_processes=processes, warm_up=False)


def surroundings() -> tuple[str | None, str, int]:
    """What a compute process sees of its server: a variable, its working directory, its parent's pid."""
    return os.environ.get("IWR_PROBE"), os.getcwd(), os.getppid()


def die() -> None:
    os._exit(3)


def sleep_then_pid(*, seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def grow(*, step_bytes: int, steps: int) -> int:
    """Allocate and touch `steps` blocks, a little at a time (what a parse of a huge body does): no
    cancellation point anywhere."""
    held = []
    for _ in range(steps):
        held.append(bytearray(step_bytes))  # zero-filled, so resident
        time.sleep(0.01)
    return len(held)


def deaf_spin(*, cpu_seconds: float) -> str:
    started = time.process_time()
    while time.process_time() - started < cpu_seconds:
        pass  # never reads its token
    return "finished"


def deaf(*, seconds: float) -> str:
    time.sleep(seconds)  # never reads its token
    return "finished"


@pytest.fixture(scope="module")
def pool(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ComputePool]:
    db = Database(f"sqlite:///{tmp_path_factory.mktemp('compute') / 'c.db'}")
    db.migrate()
    with db.session() as s:
        for name in ("b-cell", "a-cell"):
            Repository(s).add_robot(name, "iwr", [0.0] * 6, [0.0] * 6, [0.0])  # rows enough to be listed
    pool = ComputePool(db, ModelCache(db), Registry(), settings(db, 1), slots=1)
    anyio.run(pool.start)
    yield pool
    pool.shutdown()


def test_a_task_runs_in_another_process_on_its_own_database(pool: ComputePool) -> None:
    async def main() -> tuple[list[str], int]:
        names = await pool.run(Task(robot_names, {}, ("db",)), CancellationToken())
        return names, await pool.run(Task(pid), CancellationToken())

    names, child = anyio.run(main)
    assert names == ["a-cell", "b-cell"] and child != os.getpid()


def test_errors_travel_back_with_their_data(pool: ComputePool) -> None:
    async def main() -> None:
        await pool.run(Task(missing, {"robot_id": "r-1"}), CancellationToken())

    with pytest.raises(NotFound, match="no robot 'r-1'") as raised:
        anyio.run(main)
    assert raised.value.data == {"resource": "robot", "id": "r-1"}


@pytest.mark.serial  # stopped after 0.3 s and well before its 30 s of wall time
def test_a_token_set_here_stops_the_computation_there(pool: ComputePool) -> None:
    token = CancellationToken()

    async def main() -> str:
        async with anyio.create_task_group() as tg:

            async def cancel_soon() -> None:
                await anyio.sleep(0.3)
                token.cancel()

            tg.start_soon(cancel_soon)
            try:
                await pool.run(Task(steps_until_cancelled, {"seconds": 30.0}), token)
            except Cancelled:
                return "cancelled"
        return "finished"

    started = time.perf_counter()
    assert anyio.run(main) == "cancelled"
    # Stopped at its next step, not after its 30 s: 0.3-0.5 s idle; 2.5 s at load 4 (stress --cpu 4 beside the
    # suite, 2026-12-07), which a bound of 2 s failed. A third of the task's length still tells the two apart.
    assert 0.3 <= time.perf_counter() - started < 10.0
    assert pool._free == [0]  # the slot is free again


def test_the_parse_lane_and_its_bound(pool: ComputePool, monkeypatch: pytest.MonkeyPatch) -> None:
    body = ("{" + ",".join(f'"k{i}":0' for i in range(100)) + "}").encode()
    assert anyio.run(pool.call, too_many_keys, body) == 100
    monkeypatch.setattr(compute, "PARSE_QUEUE", 0)
    with pytest.raises(Overloaded) as raised:
        anyio.run(pool.call, too_many_keys, body)
    assert raised.value.data["retry_after"] == compute.PARSE_RETRY_AFTER_S


def test_a_process_that_dies_costs_one_503_and_the_pool_comes_back(pool: ComputePool) -> None:
    async def main() -> int:
        with pytest.raises(Overloaded, match="stopped"):
            await pool.run(Task(die), CancellationToken())
        return int(await pool.run(Task(pid), CancellationToken()))

    assert anyio.run(main) != os.getpid()


@pytest.fixture(scope="module")
def two(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ComputePool]:
    """Two lanes, each computation may grow its process by 150 MB."""
    db = Database(f"sqlite:///{tmp_path_factory.mktemp('two') / 'c.db'}")
    db.migrate()
    pool = ComputePool(db, ModelCache(db), Registry(), settings(db, 2), slots=2, memory_bytes=150_000_000)
    anyio.run(pool.start)
    yield pool
    pool.shutdown()
    db.dispose()


def _lane_pids(pool: ComputePool) -> list[int]:
    return [process.pid for lane in pool._lanes if lane is not None for process in compute._processes_of(lane)]


def test_a_killed_child_fails_only_its_own_computation(two: ComputePool) -> None:
    before = _lane_pids(two)
    assert len(before) == 2

    async def main() -> tuple[object, object]:
        async def one(seconds: float) -> object:
            try:
                return await two.run(Task(sleep_then_pid, {"seconds": seconds}), CancellationToken())
            except Overloaded as exc:
                return exc

        async def kill_first_lane() -> None:
            await anyio.sleep(0.5)  # both computations are in their processes
            os.kill(before[0], 9)

        async with anyio.create_task_group() as tg:
            results: dict[str, object] = {}

            async def put(name: str, seconds: float) -> None:
                results[name] = await one(seconds)

            tg.start_soon(put, "a", 2.0)
            tg.start_soon(put, "b", 2.0)
            tg.start_soon(kill_first_lane)
        return results["a"], results["b"]

    outcomes = anyio.run(main)
    lost = [o for o in outcomes if isinstance(o, Overloaded)]
    finished = [o for o in outcomes if not isinstance(o, Overloaded)]
    assert len(lost) == 1 and len(finished) == 1, outcomes  # one computation lost per killed child, not both
    assert "stopped" in str(lost[0]) and lost[0].data == {"retry_after": 1}
    assert finished[0] == before[1]  # the other lane's process finished it, untouched
    assert sorted(two._free) == [0, 1]

    async def again() -> list[int]:
        return await asyncio_gather(two, 2)

    served = anyio.run(again)
    assert before[1] in served and before[0] not in served  # the killed lane came back with a new process
    assert len(set(served)) == 2


async def asyncio_gather(pool: ComputePool, n: int) -> list[int]:
    results: list[int] = []

    async def one() -> None:
        results.append(int(await pool.run(Task(sleep_then_pid, {"seconds": 0.3}), CancellationToken())))

    async with anyio.create_task_group() as tg:
        for _ in range(n):
            tg.start_soon(one)
    return results


def test_a_computation_past_its_memory_ceiling_is_ended_and_named(two: ComputePool) -> None:
    async def main() -> object:
        with pytest.raises(WorkTooLarge) as raised:
            # 20 MB every ~10 ms up to 600 MB: past 150 MB above the idle size within a second
            await two.run(Task(grow, {"step_bytes": 20_000_000, "steps": 30}), CancellationToken())
        return raised.value

    refused = anyio.run(main)
    assert isinstance(refused, WorkTooLarge)
    assert refused.data["limit_bytes"] == 150_000_000
    reached = refused.data["estimated_bytes"]
    assert 150_000_000 < reached < 600_000_000  # ended on the way, not after the whole 600 MB
    assert "memory ceiling" in str(refused)

    async def after() -> list[int]:
        return await asyncio_gather(two, 2)

    assert len(set(anyio.run(after))) == 2  # both lanes serve again


def _deaf_run(pool: ComputePool, task: Task, reason: str) -> Overloaded:
    token = CancellationToken()

    async def main() -> Overloaded:
        async def tell() -> None:
            await anyio.sleep(0.3)
            token.cancel(reason)

        async with anyio.create_task_group() as tg:
            tg.start_soon(tell)
            with pytest.raises(Overloaded) as raised:
                await pool.run(task, token)
        return raised.value

    return anyio.run(main)


def test_a_computation_deaf_to_its_deadline_is_ended_once_it_used_the_deadlines_cpu(
    two: ComputePool, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(compute, "KILL_GRACE_S", 0.3)
    monkeypatch.setattr(two.settings, "compute_deadline_seconds", 0.2)
    # 60 s of CPU without a cancellation point: ended after ~0.5 s of it (deadline and grace), however busy the
    # machine (without the watchdog: the minute, then "finished" and no Overloaded)
    refused = _deaf_run(two, Task(deaf_spin, {"cpu_seconds": 60.0}), cancellation.DEADLINE)
    assert "past its deadline" in str(refused) and refused.data == {"retry_after": 1}


def test_a_deadline_passed_on_a_busy_machine_costs_no_kill(two: ComputePool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Past its deadline in wall time but not in CPU (waiting for the cores, here for a sleep): it runs to its end,
    and its answer is the deadline's (the token's), not an ended process's."""
    monkeypatch.setattr(compute, "KILL_GRACE_S", 0.3)
    monkeypatch.setattr(two.settings, "compute_deadline_seconds", 0.2)
    token = CancellationToken()
    token.cancel(cancellation.DEADLINE)

    async def main() -> object:
        return await two.run(Task(deaf, {"seconds": 1.5}), token)

    assert anyio.run(main) == "finished"


def test_a_computation_whose_client_left_is_ended(two: ComputePool, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(compute, "KILL_GRACE_S", 0.3)
    refused = _deaf_run(two, Task(deaf, {"seconds": 60.0}), "stop")  # nobody waits for it: no CPU needed
    assert "past its deadline" in str(refused) or "stopped" in str(refused)


def test_a_process_has_its_servers_environment_of_when_the_pool_started(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The compute processes are forks of a forkserver that this process started once, with the environment and
    directory of then (service.compute.processes); a pool started later still hands its processes this
    process's of now, as a spawned process had them: a setting changed between two pools reaches the second."""
    db = Database(f"sqlite:///{tmp_path / 'env.db'}")
    db.migrate()
    seen = []
    for value in ("first", "second"):
        monkeypatch.setenv("IWR_PROBE", value)
        (tmp_path / value).mkdir()
        monkeypatch.chdir(tmp_path / value)
        probe = ComputePool(db, ModelCache(db), Registry(), settings(db, 1), slots=1)
        try:
            seen.append(anyio.run(probe.run, Task(surroundings), CancellationToken()))
        finally:
            probe.shutdown()
    assert [(variable, Path(cwd).name) for variable, cwd, _ in seen] == [("first", "first"), ("second", "second")]
    assert all(parent != os.getpid() for _, _, parent in seen), "a fork of the forkserver, not of this process"


def test_threads_when_no_processes(tmp_path: Path) -> None:
    db = Database(f"sqlite:///{tmp_path}/t.db")
    db.migrate()
    app_registry = Registry()
    pool = ComputePool(db, ModelCache(db), app_registry, settings(db, 0), slots=1)

    async def main() -> tuple[list[str], int, tuple[int, int]]:
        names = await pool.run(Task(robot_names, {}, ("db",)), CancellationToken())
        served = await pool.run(Task(registry_of, {}, ("registry",)), CancellationToken())
        return names, await pool.call(pid), served

    assert anyio.run(main) == ([], os.getpid(), (id(app_registry), os.getpid()))  # the app's own registry
    assert len(app_registry) == 1


def cpu_and_structures(*, registry: Registry) -> tuple[float, int]:
    """The CPU this process has spent since its fork (a fork's times start at zero) and the structures its
    registry holds."""
    return time.process_time(), len(registry)


def report_two_lanes(folder: str) -> None:
    """In a process of its own, whose forkserver this starts: a warm lane under the environment the forkserver
    started with, then one under a changed environment. Prints both lanes' (CPU, structures) as JSON."""
    db = Database(f"sqlite:///{folder}/lanes.db")
    db.migrate()
    seen = []
    for probe in (None, "changed"):
        if probe:
            os.environ["IWR_PROBE"] = probe  # a setting changed after the forkserver started
        warm = Settings(database_url=db.url, compute_processes=1, warm_up=True)
        lanes = ComputePool(db, ModelCache(db), Registry(), warm, slots=1)
        try:
            anyio.run(lanes.start)
            seen.append(anyio.run(lanes.run, Task(cpu_and_structures, {}, ("registry",)), CancellationToken()))
        finally:
            lanes.shutdown()
    db.dispose()
    sys.stdout.write(json.dumps(seen) + "\n")


def test_a_warm_lane_starts_with_the_runtimes_its_forkserver_built(tmp_path: Path) -> None:
    """A compute lane forked from the forkserver takes the IWR's runtimes the forkserver built before its first
    fork (service.compute.preload), instead of spending ~0.9 s of CPU building its own; a lane started under
    another environment (the native libraries' options are read from it) builds its own."""
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            f"from tests.service.test_compute import report_two_lanes; report_two_lanes({str(tmp_path)!r})",
        ],
        capture_output=True,
        text=True,
        timeout=240,
        check=False,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    (preloaded_cpu, preloaded_structures), (own_cpu, own_structures) = json.loads(done.stdout.splitlines()[-1])
    assert preloaded_structures == own_structures == 4  # the IWR and its three structures with model terms
    assert own_cpu > 3 * preloaded_cpu, (preloaded_cpu, own_cpu)


def test_a_process_serves_from_its_own_registry(pool: ComputePool) -> None:
    async def main() -> tuple[int, int]:
        return await pool.run(Task(registry_of, {}, ("registry",)), CancellationToken())  # type: ignore[no-any-return]

    _, child = anyio.run(main)
    assert child != os.getpid()
    assert len(pool.local.registry) == 0  # nothing was built in this process's registry


def _alive(process_id: int) -> bool:
    try:
        os.kill(process_id, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{process_id}/stat").read_text().split()[2] != "Z"  # a zombie is dead, not yet reaped


@pytest.mark.serial  # refused at its 0.5 s deadline, not after the minute it asks for
def test_a_parse_past_its_deadline_is_refused_and_frees_the_parse_process(
    pool: ComputePool, monkeypatch: pytest.MonkeyPatch
) -> None:
    async def main() -> tuple[int, float, int]:
        stuck = int(await pool.call(pid))  # the parse process, started under the default deadline
        monkeypatch.setattr(pool.settings, "parse_deadline_seconds", 0.5)
        started = time.perf_counter()
        with pytest.raises(ParseTimeout) as refused:
            await pool.call(time.sleep, 60)  # a parse that would hold the process for a minute
        took = time.perf_counter() - started
        assert refused.value.data == {"limit_s": 0.5}
        # the next one starts a process, whose start-up counts in its deadline: generous, so a loaded machine
        # (a spawn and its imports took over 15 s at load 11) cannot fail it
        monkeypatch.setattr(pool.settings, "parse_deadline_seconds", 120.0)
        fresh = int(await pool.call(pid))
        return stuck, took, fresh

    stuck, took, fresh = anyio.run(main)
    assert took < 10.0, took  # the deadline (0.5 s, ~0.6 s idle), not the minute: a bound that load cannot reach
    assert fresh != stuck  # a new parse process serves the next body
    deadline = time.monotonic() + 5
    while _alive(stuck) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not _alive(stuck), "the stuck parse process was ended, not left running"
