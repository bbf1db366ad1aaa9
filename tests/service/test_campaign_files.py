"""Campaign files written the way spreadsheets, tracker software and SpatialAnalyzer write them, read back exactly."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from service.campaign_io import (
    CampaignFileError,
    ImportOptions,
    QuaternionOrder,
    campaign_records,
    joined_records,
    read_spatial_analyzer,
    read_table,
)
from tests.service.helpers import records

DESC = iwr()
JOINTS = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6"]
Records = list[dict[str, list[float]]]


@pytest.fixture(scope="module")
def truth() -> list[dict[str, list[float]]]:
    sim = perturbed_robot(DESC, seed=51)
    return records(DESC, sim, sample_workspace(DESC, 12, seed=52), seed=53)  # type: ignore[return-value]


def _same(got: list[dict[str, Any]], want: list[dict[str, list[float]]], *, atol: float = 1e-9) -> None:
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_allclose(g["joints"], w["joints"], atol=atol)
        np.testing.assert_allclose(g["position"], w["position"], atol=atol)
        np.testing.assert_allclose(g["orientation"], w["orientation"], atol=atol)


def _european(v: float) -> str:
    return repr(v).replace(".", ",")


def test_an_excel_export_with_bom_semicolons_decimal_commas_comments_and_extra_columns(truth: Records) -> None:
    # Excel in a German locale: BOM, ';', decimal commas, CRLF; columns reordered, one the service does not know.
    header = ["Operator", "X [mm]", "Y [mm]", "Z [mm]", "qw", "qx", "qy", "qz", *reversed(JOINTS)]
    lines = ["\ufeff# exported from the cell's spreadsheet", ";".join(header)]
    for r in truth:
        cells = ["anna", *map(_european, r["position"] + r["orientation"]), *map(_european, reversed(r["joints"]))]
        lines.append(";".join(cells))
    table = read_table("\r\n".join(lines) + "\r\n")
    assert table.delimiter == ";" and table.decimal_comma
    got, notes = campaign_records(table, JOINTS, ImportOptions())
    _same(got, truth)
    assert any("operator" in n for n in notes) and any("decimal commas" in n for n in notes)


def test_a_leica_style_point_file_joined_with_the_controller_joint_file(truth: Records) -> None:
    # The tracker writes metres, U95 in mm, the scalar-first quaternion as Q0…Q3, a temperature and a timestamp.
    points = ["Point ID,X [m],Y [m],Z [m],U95 [mm],Q0,Q1,Q2,Q3,Temperature [°C],Timestamp"]
    for k, r in enumerate(reversed(truth)):  # another order than the joint file's
        pid = f"P{len(truth) - k:03d}"
        x, y, z = (v / 1000 for v in r["position"])
        points.append(
            ",".join(
                [pid, repr(x), repr(y), repr(z), "0.030", *map(repr, r["orientation"]), "21.5", "2026-11-30T10:00:00"]
            )
        )
    joints = ["pose_id," + ",".join(JOINTS)]
    joints += [f"P{k + 1:03d}," + ",".join(map(repr, r["joints"])) for k, r in enumerate(truth)]
    got, notes = joined_records(read_table("\n".join(joints)), read_table("\n".join(points)), JOINTS, ImportOptions())
    _same(got, truth, atol=1e-6)  # metres → mm multiplies the float's rounding by 1000
    assert all(r["sigma_mm"] == pytest.approx(0.015) for r in got)  # U95 / 2
    assert all(r["temperature_c"] == 21.5 for r in got)
    assert any("converted to mm" in n for n in notes)


def test_a_spatial_analyzer_point_export(truth: Records) -> None:
    lines = ["// SpatialAnalyzer ASCII export", "Collection Group Target X Y Z Uncertainty"]
    lines += [
        f"A Calibration P{k + 1:03d} " + " ".join(f"{v:.6f}" for v in r["position"]) + " 0.02"
        for k, r in enumerate(truth)
    ]
    joints = ["target;" + ";".join(JOINTS)] + [
        f"P{k + 1:03d};" + ";".join(map(repr, r["joints"])) for k, r in enumerate(truth)
    ]
    got, _ = joined_records(
        read_table("\n".join(joints)), read_spatial_analyzer("\n".join(lines)), JOINTS, ImportOptions()
    )
    assert len(got) == len(truth)
    for g, w in zip(got, truth, strict=True):
        np.testing.assert_allclose(g["position"], w["position"], atol=5e-7)
        assert g["orientation"] is None and g["sigma_mm"] == 0.02


def test_quaternions_in_xyzw_order_by_option(truth: Records) -> None:
    # A table with the robot's joints q1…q4 cannot also hold a Leica-style quaternion q0…q3.
    clash = read_table(",".join(["q0", *JOINTS, "x", "y", "z"]) + "\n" + ",".join(["1"] * 14))
    with pytest.raises(CampaignFileError, match="clash with the robot's joints q1, q2, q3"):
        campaign_records(clash, JOINTS, ImportOptions())
    points = ["id,x,y,z,q0,q1,q2,q3"] + [
        f"{k}," + ",".join(map(repr, r["position"] + r["orientation"][1:] + r["orientation"][:1]))
        for k, r in enumerate(truth)
    ]
    joints = ["id," + ",".join(JOINTS)] + [f"{k}," + ",".join(map(repr, r["joints"])) for k, r in enumerate(truth)]
    got, _ = joined_records(
        read_table("\n".join(joints)),
        read_table("\n".join(points)),
        JOINTS,
        ImportOptions(quaternion_order=QuaternionOrder.XYZW),
    )
    _same(got, truth)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("q1,q2\n1,2", "no column x, y, z"),
        (",".join([*JOINTS, "x", "y", "z"]) + "\n" + ",".join(["1"] * 12 + ["abc"]), "line 2, column 13 (z): 'abc'"),
        (",".join([*JOINTS, "x", "y", "z"]) + "\n" + ",".join(["1"] * 12), "line 2: 12 cells for the 13 columns"),
        (",".join([*JOINTS[:9], "x", "y", "z"]) + "\n" + ",".join(["1"] * 12), "no column for the joint(s) l6"),
        # curl -d strips line breaks: header and rows end up on one line.
        (",".join([*JOINTS, "x", "y", "z"]) + ",".join(["1"] * 26), "line breaks were stripped"),
        ("# only a comment\n\n", "no header"),
        (",".join([*JOINTS, "x", "x", "z"]) + "\n", "columns x appear twice"),
    ],
)
def test_each_mistake_is_named_with_its_place(text: str, message: str) -> None:
    with pytest.raises(CampaignFileError, match=message.replace("(", r"\(").replace(")", r"\)")):
        table = read_table(text, expected=[*JOINTS, "x", "y", "z"])
        campaign_records(table, JOINTS, ImportOptions())


def test_join_names_the_missing_pose_ids() -> None:
    joints = read_table("id," + ",".join(JOINTS) + "\nP1," + ",".join(["1"] * 10) + "\nP2," + ",".join(["1"] * 10))
    points = read_table("id,x,y,z\nP1,1,2,3\nP9,4,5,6")
    with pytest.raises(CampaignFileError, match="no measured point: P2"):
        joined_records(joints, points, JOINTS, ImportOptions())
    with pytest.raises(CampaignFileError, match="unknown length unit 'furlong'"):
        ImportOptions(length_unit="furlong")
