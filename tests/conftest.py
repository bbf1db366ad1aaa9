"""Shared fixtures: a clean environment, the IWR description and simulated robots with known errors."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from models import Registry, RobotDescription, default_registry, iwr

SLOW_MODULES = frozenset(
    {
        "tests/optimal_design/test_acceptance.py",
        "tests/service/test_compute.py",
        "tests/service/test_concurrency.py",
        "tests/service/test_contract_fuzz.py",
        "tests/service/test_disconnect.py",
        "tests/service/test_example.py",
        "tests/service/test_generated_client.py",
        "tests/service/test_load_hardening.py",
        "tests/service/test_slow_clients.py",
        "tests/ui/test_docs.py",
        "tests/ui/test_pages.py",
    }
)
"""Modules whose every test is `slow` (their `pytestmark`): under `-m "not slow"` they are not even imported,
which saves `make test-fast` their collection (the fuzz module alone generates its schemathesis cases and
creates a PostgreSQL database at import: ~8 s here)."""

ROOT = Path(__file__).resolve().parent.parent


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    if config.getoption("markexpr") == "not slow" and _relative(collection_path) in SLOW_MODULES:
        return True
    return None


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """A module listed in SLOW_MODULES with a test that is not slow would silently drop out of test-fast."""
    fast = {_relative(item.path) for item in items if item.get_closest_marker("slow") is None}
    listed = sorted(fast & SLOW_MODULES)
    assert not listed, f"these modules have tests not marked slow; mark them or unlist the modules: {listed}"


def _relative(path: Path) -> str:
    try:
        return path.resolve().relative_to(ROOT).as_posix()
    except ValueError:
        return str(path)


SCRUBBED = ("DATABASE_URL", "CC")
"""Besides every IWR_* variable: the service's database and the compiler of the native Functions."""


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
        yield


@pytest.fixture(autouse=True)
def _clean_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    """Each test starts without them too (a test that needs one sets it with monkeypatch or passes it to
    the server it starts), whatever an earlier test left in os.environ."""
    for name in _shell_variables():
        monkeypatch.delenv(name)


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
