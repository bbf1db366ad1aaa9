"""Issue 45: validations and quick checks take the campaign files calibrations take (text/csv and multipart, the
same query options, the same readers), so a file that calibrates also validates and checks.

Each file below is written as its tool writes it (a controller's joint file under a cell's own column names with
its wrist angles in radians; a Leica-style point export in Windows-1252 with decimal commas, a reflector column and
U(95); the layout of several kinds) and sent with a column map and `joint_unit=rad`; the answer must be the JSON
form's for the same records, to the last digits the file carries (`repr` of the values: exact but for the
radians' round trip), and it says what the reader did (`import_notes`). Bad files are 4xx naming the line, the
column or the map entry, and store nothing."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import forward_kinematics, iwr, sample_workspace
from models.simulation import measure, perturbed_robot
from service.compute import limits

DESC = iwr()
U95_MM = 0.05  # the file's expanded uncertainty: σ = U(95) / 2 per record
ANGLES = [k for k, kind in enumerate(DESC.joint_kinds) if kind.name == "ANGLE"]  # q3, q4: in radians in the files
# The cell's own column names (a German controller export), mapped to the robot's joints.
NAMES = [f"Achse {k + 1}" for k in range(4)] + [f"Bein {k}" for k in range(1, 7)]
MAP = ",".join(f"{name}={joint}" for name, joint in zip(NAMES, DESC.joint_names, strict=True))
QUERY = {"columns": MAP, "joint_unit": "rad"}


def _measured(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(joints in the API's units, degrees and mm; tracker positions in mm) of `n` records of a perturbed IWR."""
    campaign = measure(
        perturbed_robot(DESC, seed=seed), sample_workspace(DESC, n, seed=seed + 1), seed=seed + 2, position_only=True
    )
    return campaign.joints * DESC.joint_to_boundary, campaign.positions


def _as_written(joints_deg: np.ndarray) -> np.ndarray:
    """The joints as the controller writes them: its revolute axes in radians."""
    out = joints_deg.copy()
    out[:, ANGLES] = np.radians(out[:, ANGLES])
    return out


def _cells(values: np.ndarray, comma: bool = False) -> list[str]:
    return [repr(float(v)).replace(".", ",") if comma else repr(float(v)) for v in values]


def _json_records(joints: np.ndarray, positions: np.ndarray) -> list[dict[str, Any]]:
    return [
        {"joints": q.tolist(), "position": p.tolist(), "sigma_mm": U95_MM / 2}
        for q, p in zip(joints, positions, strict=True)
    ]


def _tracker_files(joints: np.ndarray, positions: np.ndarray) -> dict[str, tuple[str, bytes]]:
    """The controller's joint file and the tracker's point export (its own order: reversed), joined by point id."""
    ids = [f"P{k + 1}" for k in range(len(joints))]
    joint_lines = ["Point ID;" + ";".join(NAMES)]
    joint_lines += [f"{i};" + ";".join(_cells(q)) for i, q in zip(ids, _as_written(joints), strict=True)]
    point_lines = ["Point ID;Target;X [mm];Y [mm];Z [mm];U(95) [mm]"]
    point_lines += [
        f"{i};Reflektor Ø 1.5in;" + ";".join(_cells(p, comma=True)) + f";{U95_MM}".replace(".", ",")
        for i, p in reversed(list(zip(ids, positions, strict=True)))
    ]
    return {
        "joints": ("joints.csv", "\r\n".join(joint_lines).encode()),
        "points": ("points.txt", "\r\n".join(point_lines).encode("cp1252")),
    }


def _one_file(joints: np.ndarray, positions: np.ndarray) -> str:
    """The same records as one CSV: joints under the cell's names, then the tracker's columns."""
    lines = [",".join([*NAMES, "X [mm]", "Y [mm]", "Z [mm]", "U(95) [mm]"])]
    lines += [
        ",".join([*_cells(q), *_cells(p), repr(U95_MM)]) for q, p in zip(_as_written(joints), positions, strict=True)
    ]
    return "\n".join(lines) + "\n"


def _read_as_mapped_radians(notes: list[str]) -> None:
    """The reader said what it did: the map applied, the radians converted."""
    assert any("achse_1 → q1" in n for n in notes), notes
    assert any("rad" in n and "degrees" in n for n in notes), notes


def _same_results(a: list[dict[str, Any]], b: list[dict[str, Any]]) -> None:
    assert [r["version"] for r in a] == [r["version"] for r in b]
    for x, y in zip(a, b, strict=True):
        got, want = [p["position_mm"] for p in x["per_pose"]], [p["position_mm"] for p in y["per_pose"]]
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
        assert x["position_mm"]["rms"] == pytest.approx(y["position_mm"]["rms"], abs=1e-9)
        assert x["registered"] == y["registered"]


@pytest.mark.slow  # 0.6 s here (over 0.25 s): outside the inner loop (make test-fast)
def test_a_tracker_export_validates_and_checks_as_its_records_do(client: TestClient, robot_id: str) -> None:
    joints, positions = _measured(8, 41)
    records = _json_records(joints, positions)
    url = f"/v1/robots/{robot_id}/validations"

    from_files = client.post(url, params={**QUERY, "notes": "bay 2"}, files=_tracker_files(joints, positions))
    assert from_files.status_code == 201, from_files.text
    from_json = client.post(url, json={"measurements": records})
    assert from_json.status_code == 201, from_json.text
    answer = from_files.json()
    _same_results(answer["results"], from_json.json()["results"])
    # The nominal version misses the perturbed robot by its geometry errors, the same from either form.
    assert answer["results"][0]["position_mm"]["rms"] > 0.1
    assert answer["notes"] == "bay 2" and from_json.json()["import_notes"] == []
    _read_as_mapped_radians(answer["import_notes"])
    assert any("Windows-1252" in n for n in answer["import_notes"]), answer["import_notes"]
    assert client.get(f"/v1/validations/{answer['id']}").json() == answer
    # The records stored are the JSON form's: joints back in degrees, positions joined by point id, σ = U(95)/2.
    stored = client.get(f"/v1/campaigns/{answer['campaign_id']}").json()["measurements"]
    np.testing.assert_allclose([s["joints"] for s in stored], joints, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose([s["position"] for s in stored], positions, rtol=0, atol=1e-12)
    assert all(s["sigma_mm"] == pytest.approx(U95_MM / 2) for s in stored)

    # A quick check of the one-file form (against the tolerances: the robot has only its nominal version).
    url = f"/v1/robots/{robot_id}/checks"
    checked = client.post(
        url,
        params={**QUERY, "against": "tolerances"},
        content=_one_file(joints, positions),
        headers={"content-type": "text/csv"},
    )
    assert checked.status_code == 201, checked.text
    same = client.post(url, json={"measurements": records, "against": "tolerances"})
    assert same.status_code == 201, same.text
    check, want = checked.json(), same.json()
    assert (check["verdict"], check["against"], check["measurements"]) == (want["verdict"], "tolerances", 8)
    assert check["statistic"]["chi2"] == pytest.approx(want["statistic"]["chi2"], rel=1e-9)
    assert check["statistic"]["dof"] == want["statistic"]["dof"] == 8 * 3 - 6
    np.testing.assert_allclose(
        [r["position_mm"] for r in check["per_record"]], [r["position_mm"] for r in want["per_record"]], atol=1e-9
    )
    _read_as_mapped_radians(check["import_notes"])
    assert want["import_notes"] == [] and client.get(f"/v1/checks/{check['id']}").json() == check


def _ballbar_and_tracker(seed: int) -> tuple[list[dict[str, Any]], str]:
    """A campaign of two kinds on a perturbed IWR: 6 tracker positions and 12 ballbar distances to a pivot (bar
    lengths exact plus 2 µm), as JSON records and in the layout of several kinds (a `kind` column, the
    distances in metres, the wrist in radians, the cell's column names)."""
    truth = perturbed_robot(DESC, seed=seed).truth.copy()
    # In the robot's base frame (the simulation's truth puts the tracker's frame there): a validation compares
    # tracker positions beside references without registering them.
    base = [i for i, name in enumerate(DESC.parameters.names) if name.startswith("base.")]
    truth[base] = DESC.parameters.nominal[base]
    joints = sample_workspace(DESC, 18, seed=seed + 1)
    tcp = forward_kinematics(DESC, joints, truth).positions
    rng = np.random.default_rng(seed + 2)
    pivot = tcp[6:].mean(axis=0) + np.array([0.0, 0.0, -150.0])
    degrees = joints * DESC.joint_to_boundary
    tracked = tcp[:6] + rng.normal(0, 0.01, (6, 3))
    lengths = np.linalg.norm(tcp[6:] - pivot, axis=1) + rng.normal(0, 0.002, 12)
    records: list[dict[str, Any]] = [
        {"joints": q.tolist(), "position": p.tolist()} for q, p in zip(degrees[:6], tracked, strict=True)
    ]
    records += [
        {"kind": "distance", "joints": q.tolist(), "anchor": "pivot", "distance_mm": float(d)}
        for q, d in zip(degrees[6:], lengths, strict=True)
    ]
    written = _as_written(degrees)
    lines = [",".join(["kind", "anchor", *NAMES, "x", "y", "z", "distance [m]"])]
    lines += [",".join(["tracker", "", *_cells(q), *_cells(p), ""]) for q, p in zip(written[:6], tracked, strict=True)]
    lines += [
        ",".join(["distance", "pivot", *_cells(q), "", "", "", repr(float(d) / 1000)])
        for q, d in zip(written[6:], lengths, strict=True)
    ]
    return records, "\n".join(lines) + "\n"


@pytest.mark.slow  # 0.3 s here (over 0.25 s): outside the inner loop (make test-fast)
def test_a_file_of_several_kinds_validates_and_checks_as_its_records_do(client: TestClient, robot_id: str) -> None:
    records, table = _ballbar_and_tracker(51)
    csv = {"content": table, "headers": {"content-type": "text/csv"}}
    url = f"/v1/robots/{robot_id}/validations"
    from_file = client.post(url, params=QUERY, **csv)
    assert from_file.status_code == 201, from_file.text
    from_json = client.post(url, json={"measurements": records, "anchors": {"pivot": {}}})
    assert from_json.status_code == 201, from_json.text
    _same_results(from_file.json()["results"], from_json.json()["results"])
    (nominal,) = from_file.json()["results"]
    assert nominal["registered"] and 0.1 < nominal["position_mm"]["rms"] < 10  # the pivot placed by the records
    notes = from_file.json()["import_notes"]
    _read_as_mapped_radians(notes)
    assert any("distances converted to mm" in n for n in notes), notes

    url = f"/v1/robots/{robot_id}/checks"
    checked = client.post(url, params={**QUERY, "against": "tolerances"}, **csv)
    assert checked.status_code == 201, checked.text
    same = client.post(url, json={"measurements": records, "anchors": {"pivot": {}}, "against": "tolerances"})
    assert same.status_code == 201, same.text
    assert checked.json()["statistic"] == pytest.approx(same.json()["statistic"], rel=1e-9)
    assert checked.json()["verdict"] == same.json()["verdict"] == "fine"  # within the nominal tolerances


HEADER = ",".join([*DESC.joint_names, "x", "y", "z"])
ROW = "400,150,90,45,420,420,420,420,420,420,1,2,3"


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_bad_files_are_4xx_naming_the_line_the_column_or_the_map_entry(client: TestClient, robot_id: str) -> None:
    csv = {"content-type": "text/csv"}
    for path in ("validations", "checks"):
        url = f"/v1/robots/{robot_id}/{path}"
        r = client.post(url, content=f"{HEADER}\n{ROW}\n{ROW.replace(',1,', ',two,')}\n", headers=csv)
        assert r.status_code == 400 and r.json()["line"] == 3, r.text
        assert "line 3, column 11 (x)" in r.json()["detail"]
        r = client.post(url, params={"columns": "Achse 9=q1"}, content=f"{HEADER}\n{ROW}\n", headers=csv)
        assert r.status_code == 400 and "achse_9" in r.json()["detail"], r.text
        r = client.post(url, params={"columns": "x=q11"}, content=f"{HEADER}\n{ROW}\n", headers=csv)
        assert r.status_code == 400 and "q11" in r.json()["detail"], r.text
        r = client.post(url, files={"joints": ("j.csv", b"id,q1\n1,2\n")})
        assert r.status_code == 400 and "'points' is missing" in r.json()["detail"], r.text
        r = client.post(url, content=f"{HEADER}\n{ROW}\n", headers={"content-type": "text/plain"})
        assert r.status_code == 415 and "text/csv" in r.json()["detail"], r.text
    # A query field the body refuses is named as the body's field.
    url = f"/v1/robots/{robot_id}/validations"
    r = client.post(url, params={"versions": 7}, content=f"{HEADER}\n{ROW}\n", headers=csv)
    assert r.status_code == 422 and "version 7 does not exist" in r.json()["detail"], r.text
    # More records than a check takes: the schema's limit, named, after reading (0.25 s estimated)...
    many = f"{HEADER}\n" + f"{ROW}\n" * 250
    r = client.post(f"/v1/robots/{robot_id}/checks", content=many, headers=csv)
    assert r.status_code == 422 and r.json()["field"] == "measurements", r.text
    # ... and a file far over it refused from its lines before it is read (no job form: fewer at a time).
    lines = int(limits.SYNC_BUDGET_S / limits.CHECK_S_PER_RECORD) + 10
    r = client.post(f"/v1/robots/{robot_id}/checks", content=f"{HEADER}\n" + f"{ROW}\n" * lines, headers=csv)
    problem = r.json()
    assert r.status_code == 422 and problem["type"].endswith("/work-too-large"), problem
    assert problem["use_async"] is False and f"quick check of {lines} measurements" in problem["detail"]
    assert client.get(f"/v1/robots/{robot_id}/validations").json() == []
    assert client.get(f"/v1/robots/{robot_id}/checks").json() == []
    assert math.isclose(limits.quick_check(200).seconds, 0.2)  # the largest check, well within the budget
