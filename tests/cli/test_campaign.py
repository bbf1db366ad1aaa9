"""`iwr campaign` against a live server, run as a user runs it: start an adaptive campaign on a UR5-like arm with
its first poses written to a CSV, measure them on a simulated truth into a records CSV, post it, read what is
next, and finish with a calibration; `--json` is the API's document, and a finished campaign refuses more (3)."""

from __future__ import annotations

import csv
import io
import json
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from models.description.examples import ur5_like, ur5_like_document
from models.simulation import measure, perturbed_robot
from tests.cli.helpers import api, iwr

pytestmark = pytest.mark.slow  # a live server and a few identifications

DESC = ur5_like()


@pytest.fixture(scope="module")
def server(story_url: str) -> str:
    return story_url  # the session's live service (tests/conftest.py)


def _records_csv(poses_csv: Path, out: Path) -> None:
    """The tracker's records at the poses of a CSV (degrees), as a campaign file: joints, x, y, z, qw…qz."""
    rows = list(csv.reader(io.StringIO(poses_csv.read_text())))
    joints = np.array([[float(v) for v in row] for row in rows[1:]]) / DESC.joint_to_boundary
    measured = measure(perturbed_robot(DESC, seed=8), joints, seed=9)
    lines = [",".join([*rows[0], "x", "y", "z", "qw", "qx", "qy", "qz"])]
    for k, row in enumerate(rows[1:]):
        values = [*row, *map(repr, measured.positions[k].tolist())]
        assert measured.quaternions is not None
        lines.append(",".join([*values, *map(repr, measured.quaternions[k].tolist())]))
    out.write_text("\n".join(lines) + "\n")


def _json(run: subprocess.CompletedProcess[str]) -> dict[str, Any]:
    assert run.returncode == 0, run.stderr
    return dict(json.loads(run.stdout))


def test_a_campaign_started_posted_and_finished_from_the_shell(server: str, tmp_path: Path) -> None:
    structure = tmp_path / "ur5.json"
    structure.write_text(json.dumps(ur5_like_document()))
    robot = _json(iwr(server, "robots", "create", "ur5-cli", "--structure", str(structure), "--json"))
    poses = tmp_path / "poses.csv"
    started = iwr(
        server, "campaign", "start", robot["id"], "--target-mm", "0.1", "--candidates", "100", "--csv", str(poses)
    )
    assert started.returncode == 0, started.stderr
    assert "measuring, 0 records of 60, target rms_tcp_mm 0.1 mm" in started.stdout and "measure " in started.stdout
    campaign_id = started.stdout.split()[2].rstrip(":")
    shown = _json(iwr(server, "campaign", "show", robot["id"], campaign_id, "--json"))
    assert shown == api(server, f"/v1/robots/{robot['id']}/adaptive-campaigns/{campaign_id}")
    assert len(list(csv.reader(io.StringIO(poses.read_text())))) == 1 + len(shown["next"]) == 8
    records = tmp_path / "records.csv"
    _records_csv(poses, records)
    step = _json(iwr(server, "campaign", "post", robot["id"], campaign_id, str(records), "--json"))
    assert step["identified"] and step["records"] == 7
    assert step["done"] == (step["predicted"]["rms_tcp_mm"] <= 0.1)
    upcoming = iwr(server, "campaign", "next", robot["id"], campaign_id, "--json")
    assert upcoming.returncode == 0 and json.loads(upcoming.stdout) == step["next"]
    finished = _json(iwr(server, "campaign", "finish", robot["id"], campaign_id, "--json"))
    assert finished["status"] == "finished" and finished["calibration_id"]
    assert api(server, f"/v1/calibrations/{finished['calibration_id']}")["measurements"] == 7
    late = iwr(server, "campaign", "post", robot["id"], campaign_id, str(records))
    assert late.returncode == 3 and "finished" in late.stderr
