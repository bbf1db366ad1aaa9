"""The example client of the README runs against a real server and prints a sensible report."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from tests.live import ROOT, running_server


def test_example_session(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sys.path.insert(0, str(ROOT / "examples"))
    try:
        import calibrate_cell
    finally:
        sys.path.pop(0)
    with running_server(f"sqlite:///{tmp_path}/example.db", IWR_JOB_WORKERS="0") as url:
        calibrate_cell.main(url)
    out = capsys.readouterr().out
    assert "calibration" in out and "succeeded" in out and "parameter version 2" in out
    after = float(re.search(r"residuals after:\s+([\d.]+) mm RMS", out).group(1))  # type: ignore[union-attr]
    before = float(re.search(r"residuals before:\s+([\d.]+) mm RMS", out).group(1))  # type: ignore[union-attr]
    assert after < 0.05 < before
    assert "54 identifiable parameters" in out
    assert out.count("reachable, model error") == 2
