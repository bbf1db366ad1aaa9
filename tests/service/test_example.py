"""The example client of the README runs against a real server and prints a sensible report."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from harness.live import ROOT

# A live server and a full calibration through the example client: ~14 s.
pytestmark = pytest.mark.slow


def test_example_session_with_the_system_python(story_url: str) -> None:
    """The README runs it with whatever Python the user has: the base interpreter, isolated (-I) and without
    site-packages (-S), so not one third-party package is importable."""
    interpreter = Path(sys.base_prefix) / "bin" / f"python{sys.version_info.major}.{sys.version_info.minor}"
    run = subprocess.run(
        [str(interpreter), "-I", "-S", str(ROOT / "examples" / "calibrate_cell.py"), story_url],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    out = run.stdout
    assert "calibration" in out and "succeeded" in out and "parameter version 2" in out
    after = float(re.search(r"residuals after:\s+([\d.]+) mm RMS", out).group(1))  # type: ignore[union-attr]
    before = float(re.search(r"residuals before:\s+([\d.]+) mm RMS", out).group(1))  # type: ignore[union-attr]
    assert after < 0.05 < before
    assert "54 identifiable parameters" in out
    assert out.count("reachable, model error") == 2
