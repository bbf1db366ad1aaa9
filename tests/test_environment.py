"""The developer's shell cannot change the results: conftest scrubs IWR_*, DATABASE_URL and CC."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import SUITE_SETTINGS

ROOT = Path(__file__).resolve().parent.parent


def test_no_shell_variables_reach_a_test() -> None:
    """Only the suite's own settings, at the suite's values (a shell's IWR_NATIVE_OPT_LEVEL=1 is replaced)."""
    leaked = [
        name
        for name in os.environ
        if (name.startswith("IWR_") or name in ("DATABASE_URL", "CC")) and SUITE_SETTINGS.get(name) != os.environ[name]
    ]
    assert not leaked


@pytest.mark.slow  # a second pytest in a subprocess: ~5 s here
def test_variables_set_in_the_shell_are_scrubbed() -> None:
    """The check above, in a pytest started from a shell that sets them all."""
    shell = {
        "IWR_NATIVE": "0",
        "IWR_NATIVE_OPT_LEVEL": "1",
        "IWR_API_KEY": "secret",
        "DATABASE_URL": "sqlite:////nowhere/x.db",
        "CC": "false",
    }
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "-q",
            "-p",
            "no:cacheprovider",
            "--no-cov",
            f"{Path(__file__).relative_to(ROOT)}::test_no_shell_variables_reach_a_test",
        ],
        cwd=ROOT,
        env={**os.environ, **shell},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 passed" in done.stdout
