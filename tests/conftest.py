"""Shared fixtures: a clean environment, the IWR description and simulated robots with known errors."""

from __future__ import annotations

import os
from collections.abc import Iterator

import numpy as np
import pytest

from models import Registry, RobotDescription, iwr

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
    """The session's robot runtimes, shared by the apps, job contexts and calls of the tests (a structure's
    Functions are built once per session, not once per app); a test that counts builds makes its own."""
    return Registry()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
