"""The test run's priorities (harness/priority.py): the parallel part's processes found under their root and
raised from nice 19 back to 0 once the serial part has ended, and the check that decides whether to try."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from harness.priority import BACKGROUND, can_raise, descendants, machine_is_free, raise_background


@pytest.fixture
def niced_tree() -> Iterator[tuple[subprocess.Popen[bytes], int]]:
    """A shell at nice 19 whose child sleeps (its niceness inherited): (the shell, the sleeper's pid)."""
    shell = subprocess.Popen(
        ["nice", "-n", str(BACKGROUND), "sh", "-c", "sleep 30 & echo $!; wait"], stdout=subprocess.PIPE
    )
    assert shell.stdout is not None
    sleeper = int(shell.stdout.readline())
    yield shell, sleeper
    shell.kill()
    os.kill(sleeper, 9)
    shell.wait()
    shell.stdout.close()


def test_the_tree_under_a_process_is_found(niced_tree: tuple[subprocess.Popen[bytes], int]) -> None:
    shell, sleeper = niced_tree
    assert {shell.pid, sleeper} <= set(descendants(os.getpid()))
    assert descendants(sleeper) == [sleeper]


def test_the_check_answers_for_this_user() -> None:
    # Root (or CAP_SYS_NICE) may lower a niceness; anyone else may not (tried, not assumed).
    assert can_raise() is (os.geteuid() == 0 or _has_sys_nice())


def test_every_process_at_nice_19_under_the_root_is_raised_and_no_other(
    niced_tree: tuple[subprocess.Popen[bytes], int],
) -> None:
    if not can_raise():
        pytest.skip("this user may not lower a niceness (root or CAP_SYS_NICE): make runs the two parts in turn")
    shell, sleeper = niced_tree
    # Roots of their own, not this process: under `make test` this worker is itself part of the niced tree.
    own = subprocess.Popen(
        [sys.executable, "-c", "import os, time; os.setpriority(os.PRIO_PROCESS, 0, 5); time.sleep(30)"]
    )
    try:
        while os.getpriority(os.PRIO_PROCESS, own.pid) != 5:  # until it has set its own
            pass
        assert raise_background(shell.pid) == 2
        assert [os.getpriority(os.PRIO_PROCESS, p) for p in (shell.pid, sleeper)] == [0, 0]
        assert raise_background(own.pid) == 0
        assert os.getpriority(os.PRIO_PROCESS, own.pid) == 5  # a niceness of its own choosing is kept
    finally:
        own.kill()
        own.wait()


def _has_sys_nice() -> bool:
    status = Path("/proc/self/status").read_text()
    effective = int(next(line.split()[1] for line in status.splitlines() if line.startswith("CapEff")), 16)
    return bool(effective & (1 << 23))  # CAP_SYS_NICE


@pytest.mark.parametrize(("load", "free"), [(1.2, True), (1.99, True), (2.0, False), (6.5, False)])
def test_the_parts_overlap_only_on_a_machine_free_at_the_start(
    monkeypatch: pytest.MonkeyPatch, load: float, free: bool
) -> None:
    # Two cores: the run's own install and lint leave ~1-1.5, `stress --cpu 4` 5-7.
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setattr(os, "getloadavg", lambda: (load, load, load))
    assert machine_is_free() is free
