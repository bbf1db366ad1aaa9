"""The test run's two priorities (`make pytest`): the serial part at the normal one, the parallel part started
beside it at the lowest (`nice -n 19`), then, once the serial part has ended, raised back to normal.

Why: the serial tests assert wall times and mostly wait (servers starting, deadlines, fixed-length loads), so on
their own they leave most of the two cores idle for over a minute. At nice 19 the parallel part fills that time
without taking a core from them (Linux gives a nice-19 process ~1.5 % of a core beside a nice-0 one). Left at 19
afterwards it would starve whenever anything else runs on the machine (a CI neighbour, `stress`), so it is
raised back; lowering a niceness needs the privilege to (root, or CAP_SYS_NICE).

On a machine that is busy already the overlap only hurts: the niced part gets nothing until the serial part ends,
and the serial part competes with the other work anyway (at `stress --cpu 4` it took 7 min, and a hang-up test
got a 503 from a compute slot it waited too long for). So the two parts overlap only where the machine is free
when the run starts and the priority can be raised again; elsewhere they run one after the other, as before.
Processes a test starts in a session of their own (the Celery fleets) fall into their own scheduling group where
the kernel groups by session (`sched_autogroup_enabled`), so their niceness weighs only within it: measured idle,
the serial bounds held all the same.

`python -m harness.priority --overlap` exits 0 where the two parts should overlap; `python -m harness.priority
ROOT` sets every process under ROOT (its descendants, ROOT included) still at nice 19 back to 0.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

BACKGROUND = 19
"""The parallel part's niceness while the serial part runs."""


def can_raise() -> bool:
    """Whether this process may set a process's niceness below its current one (tried on a child it sets to
    nice 19 and back)."""
    wait, release = os.pipe()
    child = os.fork()
    if child == 0:  # the child only waits to be tried on, then goes
        os.close(release)
        os.read(wait, 1)
        os._exit(0)
    os.close(wait)
    try:
        os.setpriority(os.PRIO_PROCESS, child, BACKGROUND)
        os.setpriority(os.PRIO_PROCESS, child, 0)
        return True
    except PermissionError:
        return False
    finally:
        os.close(release)
        os.waitpid(child, 0)


def descendants(root: int) -> list[int]:
    """`root` and every process below it, read from /proc (a process's parent is the fourth field of its stat)."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:  # gone meanwhile
            continue
        parent = int(stat.rsplit(")", 1)[1].split()[1])
        children.setdefault(parent, []).append(int(entry.name))
    found, todo = [], [root]
    while todo:
        pid = todo.pop()
        found.append(pid)
        todo.extend(children.get(pid, []))
    return found


def raise_background(root: int) -> int:
    """Every process under `root` at nice `BACKGROUND` set to 0; how many. Twice over, for the processes forked
    by one of them while the first pass ran (they inherit the niceness their parent had then)."""
    raised = 0
    for _ in range(2):
        for pid in descendants(root):
            try:
                if os.getpriority(os.PRIO_PROCESS, pid) == BACKGROUND:
                    os.setpriority(os.PRIO_PROCESS, pid, 0)
                    raised += 1
            except (ProcessLookupError, PermissionError):  # ended meanwhile; not ours
                continue
    return raised


def machine_is_free() -> bool:
    """Whether the last minute's load average is under the core count: the run's own install and lint leave
    ~1-1.5 on two cores, `stress --cpu 4` 5-7."""
    return os.getloadavg()[0] < (os.cpu_count() or 1)


def main(argv: list[str]) -> int:
    if argv == ["--overlap"]:
        return 0 if machine_is_free() and can_raise() else 1
    if len(argv) == 1 and argv[0].isdigit():
        raise_background(int(argv[0]))
        return 0
    sys.stderr.write("usage: python -m harness.priority --overlap | ROOT_PID\n")
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
