"""Shared fixtures: a clean environment, the IWR description and simulated robots with known errors."""

from __future__ import annotations

import ast
import gc
import itertools
import logging
import os
import re
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from _pytest.mark.expression import Expression

from harness.live import story_server
from models import Registry, RobotDescription, default_registry, iwr

ROOT = Path(__file__).resolve().parent.parent


def _marks(node: ast.AST) -> set[str]:
    """The names of the `pytest.mark.<name>` that `node` spells (an attribute, a call, a list of them)."""
    return {
        sub.attr
        for sub in ast.walk(node)
        if isinstance(sub, ast.Attribute)
        and isinstance(sub.value, ast.Attribute)
        and sub.value.attr == "mark"
        and isinstance(sub.value.value, ast.Name)
        and sub.value.value.id == "pytest"
    }


def _modules_marked() -> dict[tuple[str, bool], frozenset[str]]:
    """The test modules that mark tests `slow` or `serial`, read from their source (nothing is imported), by
    (marker, whole): with `whole`, only those whose module-level `pytestmark` carries it (every test of the
    module has it). Each file is parsed once, and only if its text names one of the markers: parsing every
    test module for each marker was 2.4 s of every pytest process's start (each xdist worker's, the serial part's)."""
    out: dict[tuple[str, bool], set[str]] = {(m, w): set() for m in ("slow", "serial") for w in (True, False)}
    for path in (ROOT / "tests").rglob("test_*.py"):
        source = path.read_text(encoding="utf-8")
        named = [m for m in ("slow", "serial") if f"mark.{m}" in source]
        if not named:
            continue
        tree = ast.parse(source)
        module_marks: set[str] = set()
        for stmt in tree.body:
            if isinstance(stmt, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "pytestmark" for t in stmt.targets
            ):
                module_marks |= _marks(stmt.value)
        every_mark = _marks(tree)
        for marker in named:
            name = path.relative_to(ROOT).as_posix()
            if marker in module_marks:
                out[(marker, True)].add(name)
            if marker in every_mark:
                out[(marker, False)].add(name)
    return {key: frozenset(names) for key, names in out.items()}


_MARKED = _modules_marked()
SLOW_MODULES = _MARKED[("slow", True)]
"""Modules whose every test is `slow` (their `pytestmark`): under `-m "not slow"` they are not even imported,
which saves `make test-fast` their collection (the contract and fuzz modules generate their schemathesis cases at
import, the fuzz module creates a PostgreSQL database too: ~8 s each here)."""

SERIAL_MODULES = _MARKED[("serial", False)]
"""Modules with tests marked `serial` (wall times, deadlines, load: they run after the parallel part, alone on
the cores). The serial part (`-m serial`, `-m "serial and not slow"`) collects only these: importing the others
(schemathesis generates the contract cases at collection) would cost it ~15 s for nothing."""


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    path, markexpr = _relative(collection_path), config.getoption("markexpr")
    if path in SLOW_MODULES and _never_selects(markexpr, slow=True):
        return True
    test_module = collection_path.name.startswith("test_") and collection_path.suffix == ".py"
    if test_module and path not in SERIAL_MODULES and _never_selects(markexpr, serial=False):
        return True
    return None


def _never_selects(markexpr: str, **fixed: bool) -> bool:
    """Whether `-m markexpr` deselects every test whose markers include (True) or lack (False) those `fixed`,
    whatever its other markers: `slow=True` for `not slow` and the two halves of `make test-fast` (`not slow and
    not serial`, then `serial and not slow`); `serial=False` for `-m serial`. Every assignment of the expression's
    other names is tried, so `not slow or serial` keeps the slow modules."""
    if not markexpr:
        return False
    expression = Expression.compile(markexpr)
    others = sorted(set(re.findall(r"[\w.-]+", markexpr)) - {*fixed, "and", "or", "not", "True", "False"})
    for values in itertools.product((False, True), repeat=len(others)):
        marked = dict(zip(others, values, strict=True), **fixed)
        if expression.evaluate(lambda name, /, marked=marked, **_: marked.get(name, False)):
            return False
    return True


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Checks the markers, then orders the modules (below). A module listed in SLOW_MODULES with a test that is
    not slow would silently drop out of test-fast, and a serial test outside SERIAL_MODULES out of the serial part
    (and so out of both `make` runs). This sees every collected item, before `-m` deselects any: the parallel part
    (`-m "not serial"`) checks the serial ones."""
    fast = {_relative(item.path) for item in items if item.get_closest_marker("slow") is None}
    listed = sorted(fast & SLOW_MODULES)
    assert not listed, f"these modules have tests not marked slow; mark them or unlist the modules: {listed}"
    serial = {_relative(item.path) for item in items if item.get_closest_marker("serial") is not None}
    unlisted = sorted(serial - SERIAL_MODULES)
    assert not unlisted, f"these modules have tests marked serial; list them in SERIAL_MODULES: {unlisted}"
    # The modules with the most slow tests first, each whole and in its own order (its module fixtures still built
    # once): pytest-xdist hands the collection out in order and workers steal from each other's ends, so the long
    # tests start early and the run ends on sub-second ones, not on one worker's fleet test while the rest idle.
    # Before them, the items that need more than the run's hang guard (the schemathesis items, 20-40 s of CPU
    # each): started last, one of them kept a worker busy alone for the run's last half minute.
    # The browser tests count as one module: each worker that runs any starts a UI server and a Chromium (package
    # scope: leaving tests/ui closes it, coming back launches another), so they are handed out as one block.
    slow = Counter(_ordering_unit(item) for item in items if item.get_closest_marker("slow") is not None)
    items.sort(key=lambda item: (not _outlasts_the_guard(item), -slow[_ordering_unit(item)]))


def _ordering_unit(item: pytest.Item) -> str:
    """What the collection is ordered by: the test's module, or the browser tests' package as a whole."""
    path = _relative(item.path)
    return "tests/ui" if path.startswith("tests/ui/") else path


def _outlasts_the_guard(item: pytest.Item) -> bool:
    marker = item.get_closest_marker("timeout")
    guard = float(item.config.getini("timeout") or 0)
    return bool(marker is not None and marker.args and float(marker.args[0]) > guard)


def _relative(path: Path) -> str:
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


SCRUBBED = ("DATABASE_URL", "CC")
"""Besides every IWR_* variable: the service's database and the compiler of the native Functions."""


SUITE_SETTINGS = {"IWR_NATIVE_OPT_LEVEL": "0"}
"""What the suite sets in place of the shell's: its native libraries built at gcc's -O0, three times faster to build
than the service's -O1 and the same numbers (models/engine/native.py). The suite builds ~80 libraries of ~40
structures and evaluates each a little: on a cold cache the builds were ~195 s of its CPU at -O1
(docs/development.md, "Test suite time"). A test of the default level sets it back with monkeypatch."""


def _shell_variables() -> list[str]:
    return [name for name in os.environ if name.startswith("IWR_") or name in SCRUBBED]


@pytest.fixture(scope="session", autouse=True)
def _clean_session_environment() -> Iterator[None]:
    """No developer's IWR_NATIVE=0, IWR_API_KEY, DATABASE_URL or CC reaches the session-wide fixtures
    (apps, compiled Functions) either. Test knobs read at import (IWR_TEST_POSTGRES,
    IWR_CONCURRENCY_SECONDS in tests/service) are read before this runs and keep working."""
    with pytest.MonkeyPatch.context() as mp:
        for name in _shell_variables():
            mp.delenv(name)
        for name, value in SUITE_SETTINGS.items():
            mp.setenv(name, value)
        yield


@pytest.fixture(autouse=True)
def _clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts without them too (a test that needs one sets it with monkeypatch or passes it to
    the server it starts), whatever an earlier test left in os.environ."""
    for name in _shell_variables():
        monkeypatch.delenv(name)
    for name, value in SUITE_SETTINGS.items():
        monkeypatch.setenv(name, value)


@pytest.fixture(autouse=True)
def _loggers_stay_enabled() -> Iterator[None]:
    """import-linter's lint_imports (tests/test_architecture.py) calls logging.config.dictConfig, which disables
    every logger that exists, the service's too. In one serial run it came after the tests that read the
    service's logs; under pytest-xdist any test may follow it in its worker: each test leaves the loggers as
    enabled as it found them."""
    loggers = logging.Logger.manager.loggerDict
    before = {name: logger.disabled for name, logger in loggers.items() if isinstance(logger, logging.Logger)}
    yield
    for name, disabled in before.items():
        logger = loggers.get(name)
        if isinstance(logger, logging.Logger):
            logger.disabled = disabled


@pytest.fixture(scope="session")
def story_url(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """One live service per test process for the story modules (the CLI's sessions and campaigns, the README's
    quick start, the example, the generated client, a retried POST), each keeping its robots apart by name:
    starting and stopping a `python -m service` with its compute and parse processes is ~7 s of CPU, and these
    seven modules each started their own."""
    with story_server(tmp_path_factory.mktemp("story")) as url:
        yield url


@pytest.fixture(scope="session")
def desc() -> RobotDescription:
    return iwr()


@pytest.fixture(scope="session")
def registry() -> Registry:
    """The session's robot runtimes, given to every app, job context and service call of the tests (a
    structure's artefacts are built once per session, not once per app). It is the library's default registry,
    so what the models tests built (they call without `runtime=`) serves the service tests too; a test that
    counts builds makes its own, and tests/service/test_registry.py checks that the service never falls back
    to the default by itself."""
    return default_registry()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


def pytest_collection_finish(session: pytest.Session) -> None:
    """What the collection built (the imported project and libraries, ~700 000 objects a worker) moved out of the
    garbage collector's reach: it lives as long as the process, and each full collection walked all of it again,
    ~0.15 s a time, over a dozen times a worker, and five times more at the end (pytest's search for unraisable
    exceptions). Objects the tests make are collected as before."""
    gc.collect()
    gc.freeze()


FINAL_PASSES = 5
"""At most as many full collections as pytest's own search for unraisable exceptions at its cleanup."""


def pytest_unconfigure(config: pytest.Config) -> None:
    """Full collections until one frees nothing, then what survives (the session's registry of every structure
    the tests built, their caches: up to 1.7 million objects in one worker) moved out of the collector's reach,
    before pytest's cleanup runs its five full collections: those then walk only what is left, not 1.4-1.6 s each
    of survivors. Every object that became garbage was collected by then, while pytest's hook for unraisable
    exceptions was still installed: a connection or file a test left open still warns and fails the run."""
    for _ in range(FINAL_PASSES):
        if gc.collect() == 0:
            break
    gc.freeze()
