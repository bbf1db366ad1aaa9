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
    Table,
    campaign_records,
    joined_records,
    read_spatial_analyzer,
    read_table,
)
from service.campaign_io.encoding import decode_text
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


# ------------------------------------------------------------------------------ as each tool writes (issue 45)
# Each file below is written the way the tool's export writes it: its encoding (Windows-1252 on a European
# Windows machine, UTF-16 from Excel's "Unicode text"), separators, decimal commas, the preamble above the header,
# the column names. `decode_text` then the readers, as the API reads an upload.
REFLECTOR = "TMC 30-B #5320"


def _joint_file(truth: Records, ids: list[str]) -> str:
    return "\n".join(
        ["Point ID;" + ";".join(JOINTS)]
        + [f"{i};" + ";".join(map(repr, r["joints"])) for i, r in zip(ids, truth, strict=True)]
    )


def _read(raw: bytes, what: str = "the 'points' file") -> tuple[Table, list[str]]:
    text, note = decode_text(raw, what)
    return read_table(text), [note] if note else []


def test_a_leica_at960_export_in_windows_1252_with_reflector_u95_and_temperature(truth: Records) -> None:
    # Leica's export on a German Windows: cp1252 (the header's °C), ';' and decimal commas, the reflector's name
    # in Target on every row, U(95) in mm, the temperature, date and time in columns of their own.
    ids = [f"Pos{k + 1:03d}" for k in range(len(truth))]
    lines = ["Point ID;Target;X [mm];Y [mm];Z [mm];U(95) [mm];Temperature [°C];Date;Time"]
    for pid, r in zip(ids, truth, strict=True):
        x, y, z = (_european(v) for v in r["position"])
        lines.append(f"{pid};{REFLECTOR};{x};{y};{z};0,024;21,4;30.11.2026;10:14:03")
    raw = "\r\n".join(lines).encode("cp1252")
    with pytest.raises(UnicodeDecodeError):
        raw.decode("utf-8")  # what the service refused before: "must be UTF-8 text"
    points, decoded = _read(raw)
    got, notes = joined_records(read_table(_joint_file(truth, ids)), points, JOINTS, ImportOptions())
    assert len(got) == len(truth)
    for g, w in zip(got, truth, strict=True):
        np.testing.assert_allclose(g["position"], w["position"], atol=1e-12)
        assert g["sigma_mm"] == pytest.approx(0.012) and g["temperature_c"] == pytest.approx(21.4)
    assert "Windows-1252" in decoded[0]
    assert any(f"reflector's name ('{REFLECTOR}' on every record)" in n for n in notes), notes
    assert not any("ignored" in n and "u95" in n for n in notes)


def test_a_leica_export_without_point_names_joins_nothing_but_reads_as_one_table(truth: Records) -> None:
    # Joints and the tracker's columns in one sheet, the reflector the only name: the rows are the poses in order.
    header = [*JOINTS, "Target", "X", "Y", "Z", "U(95)"]
    rows = [[*map(repr, r["joints"]), REFLECTOR, *map(repr, r["position"]), "0.03"] for r in truth]
    table = read_table("\n".join(",".join(row) for row in [header, *rows]))
    got, notes = campaign_records(table, JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=1e-12)
    assert all(g["sigma_mm"] == pytest.approx(0.015) for g in got)
    assert any("reflector" in n for n in notes)
    # To join two files a repeated Target is no pose id, and the message says why.
    with pytest.raises(CampaignFileError, match="a target column that repeats names the reflector"):
        joined_records(
            read_table(_joint_file(truth, [str(k) for k in range(len(truth))])), table, JOINTS, ImportOptions()
        )


def test_a_leica_at5xx_export_in_utf16_with_tabs(truth: Records) -> None:
    # Excel's "Unicode text" of the tracker's sheet: UTF-16 LE with its byte-order mark, tab-separated, metres.
    ids = [f"P{k + 1}" for k in range(len(truth))]
    lines = ["Name\tTarget\tX [m]\tY [m]\tZ [m]\tU(95) [µm]"]
    lines += [
        f"{pid}\tRRR 1.5in #A12\t" + "\t".join(repr(v / 1000) for v in r["position"]) + "\t30"
        for pid, r in zip(ids, truth, strict=True)
    ]
    raw = "\r\n".join(lines).encode("utf-16")
    assert raw[:2] == b"\xff\xfe"
    points, decoded = _read(raw)
    got, _ = joined_records(read_table(_joint_file(truth, ids)), points, JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=1e-9)
    assert all(g["sigma_mm"] == pytest.approx(0.015) for g in got)  # 30 µm U95 → σ 15 µm
    assert "UTF-16" in decoded[0]
    # Without the byte-order mark (some tools strip it), the NUL bytes of ASCII text still say UTF-16.
    text, note = decode_text("\r\n".join(lines).encode("utf-16-le"), "the 'points' file")
    assert text.startswith("Name\tTarget") and note is not None and "little-endian" in note


def test_a_hexagon_pc_dmis_csv_with_its_designator_row(truth: Records) -> None:
    # PC-DMIS: a report preamble, a lone `*` announcing the designator row TYPE,NAME,X,Y,Z,+TOL,-TOL.
    lines = ["PART NAME  : ROBOT CELL 3", "REV NUMBER : 2", "SER NUMBER : AT960-751", "*", "TYPE,NAME,X,Y,Z,+TOL,-TOL"]
    ids = [f"X48a{k + 1:03d}" for k in range(len(truth))]
    lines += [
        f"Point,{pid}," + ",".join(f"{v:.6f}" for v in r["position"]) + ",0.05,0.05"
        for pid, r in zip(ids, truth, strict=True)
    ]
    points, _ = _read("\r\n".join(lines).encode("cp1252"))
    got, notes = joined_records(read_table(_joint_file(truth, ids)), points, JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=5e-7)
    assert any("4 line(s) above the header" in n for n in notes), notes
    assert any("ignored (unknown): type, +tol, _tol" in n for n in notes), notes


def test_a_faro_cam2_report_in_inches_states_its_unit_above_the_header(truth: Records) -> None:
    # CAM2's point report of a FARO tracker: title, date and `Units: Inches` above the header, the point names
    # in `Feature Name`, measured coordinates as `Meas X` ….
    lines = ["CAM2 Measure - Robot cell 3", "Date: 11/30/2026", "Units: Inches", "Feature Name,Meas X,Meas Y,Meas Z"]
    ids = [f"Point {k + 1}" for k in range(len(truth))]
    lines += [f"{pid}," + ",".join(f"{v / 25.4:.8f}" for v in r["position"]) for pid, r in zip(ids, truth, strict=True)]
    points, _ = _read("\r\n".join(lines).encode("cp1252"))
    got, notes = joined_records(read_table(_joint_file(truth, ids)), points, JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=2e-6)
    assert any("its length unit: in" in n for n in notes) and any("×25.4" in n for n in notes), notes


def test_an_api_tracker_s_spatial_analyzer_csv_and_ascii_exports_in_windows_1252(truth: Records) -> None:
    # An API (Automated Precision) tracker measured through SpatialAnalyzer: its CSV point export
    # (Collection, Group, Point, X, Y, Z) and its ASCII export with a Windows-1252 comment line.
    ids = [f"T{k + 1}" for k in range(len(truth))]
    csv_lines = ["Collection,Group,Point,X,Y,Z"] + [
        f"A,Robot,{pid}," + ",".join(f"{v:.6f}" for v in r["position"]) for pid, r in zip(ids, truth, strict=True)
    ]
    points, _ = _read("\r\n".join(csv_lines).encode("cp1252"))
    got, notes = joined_records(read_table(_joint_file(truth, ids)), points, JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=5e-7)
    assert not any("ignored" in n for n in notes), notes  # collection and group are known, not used
    ascii_lines = ["// Radian API tracker, Temperatur 20,5 °C, Einheit mm, Unsicherheit ± 15 µm"] + [
        f"A Robot {pid} " + " ".join(f"{v:.6f}" for v in r["position"]) for pid, r in zip(ids, truth, strict=True)
    ]
    text, note = decode_text("\r\n".join(ascii_lines).encode("cp1252"), "the 'points' file")
    got, _ = joined_records(read_table(_joint_file(truth, ids)), read_spatial_analyzer(text), JOINTS, ImportOptions())
    np.testing.assert_allclose([g["position"] for g in got], [r["position"] for r in truth], atol=5e-7)
    assert note is not None and "Windows-1252" in note


def test_what_no_text_encoding_reads_is_named() -> None:
    with pytest.raises(CampaignFileError, match="not valid UTF-16"):
        decode_text(b"\xff\xfeX\x00\x00\xd8", "the 'points' file")  # a lone surrogate
    with pytest.raises(CampaignFileError, match="NUL bytes"):
        decode_text(b"x,y,z\n\x00\x00\x00\x00\x01\x02\x03\x00", "the CSV body")
