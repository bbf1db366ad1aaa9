"""Rows that carry several points (issue 45): a motion-capture body's markers or a reflector nest read at the same
joints, as `x1, y1, z1, …` or `marker2_x …`. Each row becomes the TCP's tracker record and a reflector record per
other point; the file's length unit reaches its prismatic joints; a marker scatter column is the records' σ."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models.description.examples import ur5_like_document
from service.campaign_io import CampaignFileError, ImportOptions
from service.campaign_io.columns import RobotColumns, parse_column_map
from service.files.csv_codec import parse_campaign

ROBOT = RobotColumns(("q1", "q2", "q3"), {"lift": "q1", "shoulder": "q2", "elbow": "q3"}, frozenset({"q2", "q3"}))
"""A prismatic lift and two revolute joints, named by a URDF as `lift`, `shoulder`, `elbow`."""
ROWS = 5


def _truth() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(joints in mm and degrees, points (rows, 3, 3) in mm, σ in mm): the numbers the file is written from."""
    rng = np.random.default_rng(7)
    joints = np.column_stack([rng.uniform(0, 350, ROWS), rng.uniform(-90, 90, (ROWS, 2))])
    return joints, rng.uniform(-900, 900, (ROWS, 3, 3)), rng.uniform(0.05, 0.6, ROWS)


def _csv(header: list[str], rows: np.ndarray) -> str:
    return "\n".join([",".join(header), *(",".join(repr(float(v)) for v in row) for row in rows)]) + "\n"


def _file(
    columns: list[str], *, metres: bool = True, radians: bool = True, sigma: str = "marker_std_mm"
) -> tuple[str, np.ndarray, np.ndarray, np.ndarray]:
    """A file as a mocap script writes it: the points' columns `columns` (9, point by point), lift, shoulder,
    elbow, the scatter; lengths in metres and angles in radians unless told otherwise, no unit in the header."""
    joints, points, sigma_mm = _truth()
    length = 1e-3 if metres else 1.0
    sent_joints = joints * [length, *(2 * [np.pi / 180 if radians else 1.0])]
    body = np.hstack([points.reshape(ROWS, 9) * length, sent_joints, sigma_mm[:, None]])
    return _csv([*columns, "lift", "shoulder", "elbow", sigma], body), joints, points, sigma_mm


NUMBERED = [f"{a}{k}" for k in (1, 2, 3) for a in "xyz"]


def _split(records: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], dict[str, list[dict[str, Any]]]]:
    tcp = [r for r in records if "kind" not in r]
    reflectors: dict[str, list[dict[str, Any]]] = {}
    for r in records:
        if r.get("kind") == "reflector":
            reflectors.setdefault(r["reflector"], []).append(r)
    return tcp, reflectors


def test_numbered_points_become_the_tcp_s_records_and_reflector_records() -> None:
    text, joints, points, sigma = _file(NUMBERED)
    got, notes = parse_campaign(text, options=ImportOptions(length_unit="m", joint_unit="rad"), robot=ROBOT)
    tcp, reflectors = _split(got)
    assert [r.get("kind") for r in got[:3]] == [None, "reflector", "reflector"]  # a row's records together
    assert set(reflectors) == {"p2", "p3"}
    np.testing.assert_allclose([r["position"] for r in tcp], points[:, 0], rtol=1e-12)
    for k, name in ((1, "p2"), (2, "p3")):
        np.testing.assert_allclose([r["position"] for r in reflectors[name]], points[:, k], rtol=1e-12)
        np.testing.assert_allclose([r["joints"] for r in reflectors[name]], joints, rtol=1e-12)
    # The lift in metres by the file's length unit, the arm in radians by the option; σ in mm by its name.
    np.testing.assert_allclose([r["joints"] for r in tcp], joints, rtol=1e-12)
    np.testing.assert_allclose([r["sigma_mm"] for r in tcp], sigma, rtol=1e-12)
    np.testing.assert_allclose([r["sigma_mm"] for r in reflectors["p3"]], sigma, rtol=1e-12)
    said = " | ".join(notes)
    assert "3 points a row: p1 read as the TCP's tracker records, p2, p3 as reflector records" in said
    assert "joint column q1 is in m: converted to mm" in said and "columns ignored" not in said


def test_a_header_s_units_need_no_option() -> None:
    header = [f"{c} [m]" for c in NUMBERED]
    text, joints, points, _ = _file(header)
    text = text.replace("lift,shoulder,elbow", "lift [m],shoulder [rad],elbow [rad]", 1)
    got, _ = parse_campaign(text, robot=ROBOT)
    tcp, reflectors = _split(got)
    np.testing.assert_allclose([r["joints"] for r in tcp], joints, rtol=1e-12)
    np.testing.assert_allclose([r["position"] for r in reflectors["p2"]], points[:, 1], rtol=1e-12)


def test_a_prismatic_joint_stated_in_mm_keeps_it_under_a_metre_length_unit() -> None:
    text, joints, points, _ = _file(NUMBERED, radians=False)
    mm = joints[:, 0] * 1000.0  # the lift written in mm, its header says so; the points stay in metres
    lines = text.splitlines()
    lines[0] = lines[0].replace("lift", "lift [mm]")
    lines[1:] = [
        ",".join([*line.split(",")[:9], repr(float(v)), *line.split(",")[10:]])
        for line, v in zip(lines[1:], mm, strict=True)
    ]
    got, _ = parse_campaign("\n".join(lines), options=ImportOptions(length_unit="m"), robot=ROBOT)
    tcp, _ = _split(got)
    np.testing.assert_allclose([r["joints"] for r in tcp], np.column_stack([mm, joints[:, 1:]]), rtol=1e-12)
    np.testing.assert_allclose([r["position"] for r in tcp], points[:, 0], rtol=1e-12)


def test_the_default_length_unit_leaves_a_prismatic_joint_in_mm() -> None:
    text, joints, _, _ = _file(NUMBERED, metres=False, radians=False)
    got, notes = parse_campaign(text, robot=ROBOT)
    np.testing.assert_allclose([r["joints"] for r in _split(got)[0]], joints, rtol=1e-12)
    assert not any("converted" in n for n in notes)


def test_named_points_and_a_column_map_choosing_the_tcp() -> None:
    named = [f"marker{k}_{a}" for k in (1, 2, 3) for a in "xyz"]
    text, _, points, _ = _file(named)
    got, _ = parse_campaign(text, options=ImportOptions(length_unit="m", joint_unit="rad"), robot=ROBOT)
    tcp, reflectors = _split(got)
    assert set(reflectors) == {"marker2", "marker3"}
    np.testing.assert_allclose([r["position"] for r in tcp], points[:, 0], rtol=1e-12)
    # The map sends point 3 to x, y, z: it is the TCP, points 1 and 2 the reflectors.
    text, _, points, _ = _file(NUMBERED)
    options = ImportOptions(length_unit="m", joint_unit="rad", columns=parse_column_map("x3=x,y3=y,z3=z"))
    got, notes = parse_campaign(text, options=options, robot=ROBOT)
    tcp, reflectors = _split(got)
    assert set(reflectors) == {"p1", "p2"}
    np.testing.assert_allclose([r["position"] for r in tcp], points[:, 2], rtol=1e-12)
    np.testing.assert_allclose([r["position"] for r in reflectors["p1"]], points[:, 0], rtol=1e-12)
    assert any("x, y, z read as the TCP's tracker records, p1, p2 as reflector" in n for n in notes)
    # A map may also name a column as a further point's coordinate.
    renamed = text.replace("x2,y2,z2", "Xb,Yb,Zb", 1)
    options = ImportOptions(length_unit="m", joint_unit="rad", columns=parse_column_map("Xb=x2,Yb=y2,Zb=z2"))
    again, _ = parse_campaign(renamed, options=options, robot=ROBOT)
    np.testing.assert_allclose([r["position"] for r in _split(again)[1]["p2"]], points[:, 1], rtol=1e-12)


@pytest.mark.parametrize(("name", "factor"), [("marker_std_mm", 1.0), ("std_mm", 1.0), ("sigma", 1.0), ("U(95)", 0.5)])
def test_the_records_sigma_by_the_column_s_name(name: str, factor: float) -> None:
    # `_mm` in a name is its unit; a name without one is in the file's length unit, so these state [mm].
    header = name if name.endswith("_mm") else f"{name} [mm]"
    text, _, _, sigma = _file(NUMBERED, sigma=header)
    got, _ = parse_campaign(text, options=ImportOptions(length_unit="m", joint_unit="rad"), robot=ROBOT)
    np.testing.assert_allclose(
        np.array([r["sigma_mm"] for r in got], dtype=float), np.repeat(sigma * factor, 3), rtol=1e-12
    )


@pytest.mark.parametrize(
    ("columns", "message"),
    [
        ([*NUMBERED[:5], "w2", *NUMBERED[6:]], r"point p2 .* has the column\(s\) x2, y2 but no z"),
        (["x", "y", "w", *NUMBERED[3:]], r"column\(s\) x, y beside the numbered points but not all of x, y, z"),
    ],
)
def test_a_point_without_a_coordinate_is_named(columns: list[str], message: str) -> None:
    text, _, _, _ = _file(columns)
    with pytest.raises(CampaignFileError, match=message):
        parse_campaign(text, options=ImportOptions(length_unit="m", joint_unit="rad"), robot=ROBOT)


def test_a_refusal_over_http_names_the_column(client: TestClient) -> None:
    made = client.post("/v1/robots", json={"name": "arm", "structure": ur5_like_document()})
    assert made.status_code == 201, made.text
    header = [f"q{k}" for k in range(1, 7)] + ["x1", "y1", "z1", "x2", "y2"]
    answer = client.post(
        f"/v1/robots/{made.json()['id']}/calibrations",
        content=_csv(header, np.zeros((3, len(header)))).encode(),
        headers={"content-type": "text/csv"},
    )
    assert 400 <= answer.status_code < 500, answer.text
    assert "x2, y2 but no z" in answer.json()["detail"], answer.text
