"""The command line and the JSON the HTTP layer will serve."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from models import RobotDescription
from models.error_analysis import SUBSYSTEMS, error_analysis
from models.error_analysis.__main__ import main
from models.error_analysis.export import result_json

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _numbers(tree: Any) -> list[float]:
    if isinstance(tree, dict):
        return [x for v in tree.values() for x in _numbers(v)]
    if isinstance(tree, list):
        return [x for v in tree for x in _numbers(v)]
    return [float(tree)] if isinstance(tree, int | float) and not isinstance(tree, bool) else []


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_cli_writes_summary_json_and_plots(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out_json, plot, plot_axes = tmp_path / "out" / "ea.json", tmp_path / "ea.png", tmp_path / "axes.png"
    argv = ["--poses", "4", "--draws", "3", "--seed", "1", "--dh-angle-deg", "0.2"]
    argv += ["--json", str(out_json), "--plot", str(plot), "--plot-axes", str(plot_axes)]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    assert "thesis's claims" in printed and "carriage" in printed and "hexapod" in printed
    data = json.loads(out_json.read_text())
    assert (data["n_poses"], data["n_draws"], data["seed"]) == (4, 3, 1)
    assert data["tolerances"]["dh_angle_deg"] == pytest.approx(0.2)
    assert set(data["subsystems"]) == set(SUBSYSTEMS)
    block = data["subsystems"]["whole"]["exact"]
    assert set(block["position"]["rms_mm"]) == {"x", "y", "z"}
    assert set(block["orientation"]["rms_deg"]) == {"x", "y", "z"}
    assert len(data["per_pose"]["whole"]["exact"]["position_rms_mm"]) == 4
    assert all(math.isfinite(x) for x in _numbers(data))
    for path in (plot, plot_axes):
        assert path.read_bytes()[:8] == PNG_MAGIC
        assert path.stat().st_size > 20_000


def test_json_export_is_strict_json_in_boundary_units(desc: RobotDescription) -> None:
    res = error_analysis(desc, n_poses=3, n_draws=5, seed=3)
    data = result_json(res)
    json.dumps(data, allow_nan=False)
    deg = data["subsystems"]["carriage"]["exact"]["orientation"]["max_abs_deg"]["z"]
    rad = abs(res.errors["carriage"].exact[..., 5]).max()
    assert deg == pytest.approx(rad * 180.0 / math.pi)
    q3_deg = data["per_pose"]["joints"][0][2]
    assert q3_deg == pytest.approx(res.joints[0, 2] * 180.0 / math.pi)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_module_runs_as_a_script(tmp_path: Path) -> None:
    out = tmp_path / "r.json"
    done = subprocess.run(
        [sys.executable, "-m", "models.error_analysis", "--poses", "2", "--draws", "2", "--json", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert json.loads(out.read_text())["n_poses"] == 2


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--poses", "0"], "n_poses"),
        (["--draws", "-3"], "n_draws"),
        (["--distribution", "gauss"], "distribution"),
        (["--leg-offset-mm", "-0.5"], "leg_offset"),
    ],
)
def test_cli_reports_bad_input(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.out == ""
