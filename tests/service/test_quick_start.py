"""The README's five-minute quick start, run as a user runs it: its shell block against a live server, in a
scratch directory with the repository's example files."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from harness.live import ROOT

pytestmark = pytest.mark.slow  # a live server and an IWR calibration: a few seconds


def test_the_quick_start_calibrates_and_writes_its_report(tmp_path: Path, story_url: str) -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Five minutes")[1]
    block = re.search(r"```sh\n(.*?)```", section, re.DOTALL)
    assert block is not None, "the quick start has a shell block"
    if shutil.which("curl") is None:
        pytest.skip("curl is not installed")
    (tmp_path / "examples").mkdir()
    shutil.copy(ROOT / "examples" / "campaign.csv", tmp_path / "examples" / "campaign.csv")
    # The only story that names its robot `cell-3`, as a new user would: the session's service has no other.
    script = block.group(1).replace("API=http://127.0.0.1:8000", f"API={story_url}")
    run = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", script],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert run.returncode == 0, run.stderr
    assert "calibration " in run.stdout
    assert (tmp_path / "report.pdf").read_bytes().startswith(b"%PDF")
    assert "Calibration of cell-3" in (tmp_path / "report.html").read_text()
