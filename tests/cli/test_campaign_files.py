"""`iwr validate` and `iwr check` send the campaign file to the service as `iwr calibrate` does (issue 45): the
file's bytes as they are, `--columns` and `--joint-unit` as the query's options, so a file that calibrates also
validates and checks. A stand-in server records what is sent; a live one calibrates, validates and checks a
controller's file under its own column names with its wrists in radians, each answer the API's to the same
records as JSON."""

from __future__ import annotations

import json
import math
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any, ClassVar
from urllib.parse import parse_qs, urlsplit

import numpy as np
import pytest

from iwr_client import Client
from iwr_client.cli import main
from models import iwr as iwr_description
from models import sample_workspace
from models.simulation import measure, perturbed_robot
from tests.cli.helpers import StandIn, api, iwr, serving

DESC = iwr_description()
NAMES = [f"Achse {k + 1}" for k in range(4)] + [f"Bein {k}" for k in range(1, 7)]
MAP = ",".join(f"{name}={joint}" for name, joint in zip(NAMES, DESC.joint_names, strict=True))
ANGLES = [k for k, kind in enumerate(DESC.joint_kinds) if kind.name == "ANGLE"]


class _Recorder(StandIn):
    """Keeps each POST (path, query, content type, body) and answers a validation's or a check's document."""

    SEEN: ClassVar[list[tuple[str, dict[str, list[str]], str, bytes]]] = []
    ANSWER: ClassVar[dict[str, Any]] = {
        "id": "v1",
        "measurements": 2,
        "measurement": "position",
        "results": [{"version": 1, "position_mm": {"rms": 0.5, "max": 0.7}}],
        "verdict": "fine",
        "version": 1,
        "statistic": {"chi2": 1.0, "threshold": 9.0, "alpha": 0.01, "p_value": 0.9},
        "recommendation": {"message": "nothing to do"},
        "import_notes": ["columns read as: achse_1 → q1", "joint column q3 is in rad: converted to degrees"],
    }

    def do_POST(self) -> None:
        parts = urlsplit(self.path)
        body = self.rfile.read(int(self.headers["Content-Length"]))
        self.SEEN.append((parts.path, parse_qs(parts.query), self.headers["Content-Type"], body))
        self.answer_json(201, self.ANSWER)


@pytest.fixture
def recorder() -> Iterator[str]:
    _Recorder.SEEN.clear()
    with serving(_Recorder) as url:
        yield url


def test_validate_and_check_send_the_file_as_it_is_with_the_column_map(
    recorder: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    campaign = tmp_path / "export.csv"
    raw = "Achse 1;Achse 3;X [mm];Y [mm];Z [mm]\r\n1,5;0,25;1;2;3\r\n".encode("cp1252")
    campaign.write_bytes(raw)
    run = ["validate", "r1", str(campaign), "--columns", MAP, "--joint-unit", "rad", "--version", "1", "--version", "2"]
    assert main(["--url", recorder, *run]) == 0
    out = capsys.readouterr().out
    assert "file: columns read as: achse_1 → q1" in out and "file: joint column q3 is in rad" in out
    assert main(["--url", recorder, "check", "r1", str(campaign), "--columns", MAP, "--noise-mm", "0.02"]) == 0
    assert "file: joint column q3 is in rad" in capsys.readouterr().out
    validation, check = _Recorder.SEEN
    assert validation[0] == "/v1/robots/r1/validations" and check[0] == "/v1/robots/r1/checks"
    assert validation[1] == {"columns": [MAP], "joint_unit": ["rad"], "versions": ["1", "2"]}
    assert check[1] == {"columns": [MAP], "noise_position_mm": ["0.02"]}
    # The bytes as written (no client-side reading: no GET of the robot, no re-encoding), as text/csv.
    assert validation[2:] == check[2:] == ("text/csv", raw)


def test_a_file_s_length_unit_goes_with_it(recorder: str, tmp_path: Path) -> None:
    # A mocap export (several points a row, lengths in metres, radians): --length-unit and --joint-unit go as the
    # query's options, the file as written.
    campaign = tmp_path / "mocap.csv"
    raw = b"x1,y1,z1,x2,y2,z2,q1,q2,marker_std_mm\n0.1,0.2,0.3,0.4,0.5,0.6,0.25,1.5,0.2\n"
    campaign.write_bytes(raw)
    assert main(["--url", recorder, "validate", "r1", str(campaign), "--length-unit", "m", "--joint-unit", "rad"]) == 0
    assert main(["--url", recorder, "check", "r1", str(campaign), "--length-unit", "m"]) == 0
    validation, check = _Recorder.SEEN
    assert validation[1] == {"length_unit": ["m"], "joint_unit": ["rad"]} and check[1] == {"length_unit": ["m"]}
    assert validation[2:] == check[2:] == ("text/csv", raw)
    with pytest.raises(ValueError, match="length_unit too"):
        Client(recorder).calibrate("r1", [{"joints": [0.0] * 10, "position": [1.0, 2.0, 3.0]}], length_unit="m")


def test_records_go_as_json_and_a_column_map_is_for_files_only(recorder: str) -> None:
    records = [{"joints": [0.0] * 10, "position": [1.0, 2.0, 3.0]}]
    Client(recorder).validate("r1", records, versions=[2])
    (_, query, content_type, body) = _Recorder.SEEN[0]
    assert (query, content_type) == ({}, "application/json")
    assert json.loads(body) == {"measurements": records, "versions": [2]}
    with pytest.raises(ValueError, match="columns and joint_unit say how to read a campaign file"):
        Client(recorder).check("r1", records, columns=MAP)


# -- against a live server -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def server(story_url: str) -> str:
    return story_url  # the session's live service (tests/conftest.py)


def _controller_file(path: Path, n: int, seed: int) -> list[dict[str, Any]]:
    """`n` pose records of one perturbed IWR (the same robot whatever `seed`: it picks the poses and the noise)
    written as the cell's controller does (its column names, its wrists in radians, `;`-separated); the records
    as the API's JSON takes them."""
    sim = perturbed_robot(DESC, seed=61)
    measured = measure(sim, sample_workspace(DESC, n, seed=seed), seed=seed + 1)
    assert measured.quaternions is not None
    joints = measured.joints * DESC.joint_to_boundary
    written = joints.copy()
    written[:, ANGLES] = measured.joints[:, ANGLES]  # radians, as the controller keeps them
    lines = [";".join([*NAMES, "X", "Y", "Z", "QW", "QX", "QY", "QZ"])]
    for row in np.hstack([written, measured.positions, measured.quaternions]):
        lines.append(";".join(repr(float(v)) for v in row))
    path.write_text("\n".join(lines) + "\n")
    return [
        {"joints": q.tolist(), "position": p.tolist(), "orientation": o.tolist()}
        for q, p, o in zip(joints, measured.positions, measured.quaternions, strict=True)
    ]


def _post(url: str, path: str, body: dict[str, Any]) -> Any:
    """The API's answer to records sent as JSON, without the client under test."""
    request = urllib.request.Request(
        url + path, data=json.dumps(body).encode(), headers={"Content-Type": "application/json"}, method="POST"
    )
    with urllib.request.urlopen(request, timeout=120) as answer:
        return json.load(answer)


@pytest.mark.slow  # a live server, a calibration, two validations and two checks
def test_a_controller_file_calibrates_validates_and_checks_under_its_column_map(server: str, tmp_path: Path) -> None:
    robot = json.loads(iwr(server, "robots", "create", "cell-files", "--json").stdout)
    campaign = tmp_path / "campaign.csv"
    _controller_file(campaign, 40, 71)
    options = ["--columns", MAP, "--joint-unit", "rad", "--json"]
    calibrated = iwr(server, "calibrate", robot["id"], str(campaign), "--sync", "--noise-mm", "0.025", *options)
    assert calibrated.returncode == 0, calibrated.stderr
    assert json.loads(calibrated.stdout)["parameter_version"] == 2

    fresh = tmp_path / "fresh.csv"
    records = _controller_file(fresh, 12, 81)
    run = iwr(server, "validate", robot["id"], str(fresh), "--version", "1", "--version", "2", *options)
    assert run.returncode == 0, run.stderr
    document = json.loads(run.stdout)
    assert document == api(server, f"/v1/validations/{document['id']}")
    as_json = _post(server, f"/v1/robots/{robot['id']}/validations", {"measurements": records, "versions": [1, 2]})
    for got, want in zip(document["results"], as_json["results"], strict=True):
        assert got["position_mm"]["rms"] == pytest.approx(want["position_mm"]["rms"], abs=1e-9)
    # On poses it was not fitted to, the calibrated version is within twice the tracker's noise (σ 0.025 mm per
    # axis: 0.043 mm of 3-D RMS; 0.056 measured), the nominal, in the tracker's frame, metres from it.
    nominal, calibrated_version = (r["position_mm"]["rms"] for r in document["results"])
    assert calibrated_version < 2 * math.sqrt(3) * 0.025 < 1000 < nominal
    assert any("achse_1 → q1" in n for n in document["import_notes"]) and as_json["import_notes"] == []

    check = iwr(server, "check", robot["id"], str(fresh), "--noise-mm", "0.025", *options)
    assert check.returncode == 0, check.stderr  # fine: the robot is as calibrated
    found = json.loads(check.stdout)
    same = _post(server, f"/v1/robots/{robot['id']}/checks", {"measurements": records, "noise": {"position_mm": 0.025}})
    assert (found["verdict"], found["version"]) == (same["verdict"], 2) == ("fine", 2)
    assert found["statistic"]["chi2"] == pytest.approx(same["statistic"]["chi2"], rel=1e-9)
