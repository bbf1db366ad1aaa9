"""Property-based fuzz of the campaign and parameter readers (issue 48): whatever the file, records or an error
the service answers with a 4xx problem, never one it answers 500, and never a second's work.

Files are drawn in the shapes instrument software, controllers and spreadsheets write (a header of joint,
position, orientation, sigma, time, reference, kind and unknown columns with units; `,` `;` or tab; LF, CRLF or
CR line ends; a byte-order mark; comments), and their cells from the edges of what a reader meets: floats at and
beyond the double's range (`1e308`, `1e400`, `5e-324`), NaN and infinity, decimal commas, thousands separators,
hexadecimal, booleans, ISO times, quotes, huge digit strings. The oracle is the service's own mapping of errors to
problems (`service.http.problems.lookup`): any exception a reader or the schema raises must map to a 4xx. `make test`
draws IWR_READER_FUZZ_EXAMPLES (default 60) per property, `make fuzz` 2 000."""

from __future__ import annotations

import contextlib
import os
from datetime import timedelta
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from service.campaign_io import read_spatial_analyzer
from service.files.campaign_requests import CampaignQuery, calibration_fields
from service.files.csv_codec import joined_campaign, parse_campaign
from service.files.parameters_csv import parse_parameters
from service.http import problems
from service.schemas.calibrations import CalibrationCreate
from service.schemas.versions import ParameterVersionImport

EXAMPLES = int(os.environ.get("IWR_READER_FUZZ_EXAMPLES", "60"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=timedelta(seconds=1),  # the bound on any refusal
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    derandomize=EXAMPLES <= 60,  # reproducible in `make test`; `make fuzz` explores
)

COLUMNS = [
    *(f"q{k}" for k in range(1, 8)),
    "A1",
    "J2",
    "axis3",
    *(f"l{k}" for k in range(1, 7)),
    "x",
    "y",
    "z",
    "X [m]",
    "Y (mm)",
    "z [in]",
    "qw",
    "qx",
    "qy",
    "qz",
    "q0",
    "sigma_mm",
    "uncertainty",
    "time",
    "reference",
    "kind",
    "anchor",
    "plane",
    "point",
    "camera",
    "u",
    "v",
    "distance_mm",
    "id",
    "Point ID",
    "notes",
    "",
    "q1 [deg]",
    "A2 [rad]",
]
EDGE_CELLS = [
    "0",
    "1",
    "-2.5",
    "400",
    "1e308",
    "-1e308",
    "1e400",
    "-1e400",
    "5e-324",
    "1e-400",
    "nan",
    "NaN",
    "inf",
    "-Infinity",
    "1,5",
    "1.000,5",
    "1_000",
    "0x10",
    "1e",
    ".",
    "-",
    "",
    " ",
    "true",
    "yes",
    "x",
    "2026-12-06T12:00:00Z",
    "2026-13-45T99:99:99",
    "1" * 400,
    "9" * 5000 + ".5",
    '"1,2"',
    '"',
    "distance",
    "point",
    "plane",
    "image",
    "tracker",
    "position",
    "a1",
    "é",
    "\x00",
]
cells = st.one_of(st.sampled_from(EDGE_CELLS), st.floats(allow_nan=True).map(repr), st.text(max_size=6))


@st.composite
def tables(draw: st.DrawFn, columns: list[str] = COLUMNS) -> str:
    header = draw(st.lists(st.sampled_from(columns), min_size=1, max_size=14))
    delimiter = draw(st.sampled_from([",", ";", "\t"]))
    end = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    rows = draw(
        st.lists(
            st.lists(cells, min_size=max(0, len(header) - 1), max_size=len(header) + 1).map(delimiter.join),
            max_size=8,
        )
    )
    lines = [delimiter.join(header), *rows]
    if draw(st.integers(0, 4)) == 0:
        lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(["# comment", "", "   "])))
    text = end.join(lines) + draw(st.sampled_from(["", end]))
    return ("\ufeff" if draw(st.integers(0, 9)) == 0 else "") + text


def _answered(exc: BaseException) -> None:
    status = problems.lookup(exc)[0]
    assert status < 500, f"{type(exc).__name__}: {exc} would be a {status}"


def _as_body(measurements: list[dict[str, object]], notes: list[str]) -> None:
    query = CampaignQuery(None, None, None, None, None, None, None, [])  # type: ignore[arg-type]
    payload = {"measurements": measurements, "import_notes": notes, **calibration_fields(measurements, query)}
    with contextlib.suppress(ValidationError):  # a 422 naming the field
        CalibrationCreate.model_validate(payload)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@FUZZ
@given(tables())
def test_any_campaign_csv_is_records_or_a_4xx(text: str) -> None:
    try:
        measurements, notes = parse_campaign(text)
    except Exception as exc:  # the oracle: the service's own mapping
        _answered(exc)
        return
    _as_body(measurements, notes)


@pytest.mark.slow  # ~2 s here: outside the inner loop (make test-fast)
@FUZZ
@given(tables(["id", "Point ID", "pose", *COLUMNS[:12]]), tables(["id", "Point ID", "pose", *COLUMNS[13:20]]))
def test_any_joint_and_point_files_are_records_or_a_4xx(joints: str, points: str) -> None:
    try:
        measurements, notes = joined_campaign(joints, points, spatial_analyzer=False)
    except Exception as exc:
        _answered(exc)
        return
    _as_body(measurements, notes)


@st.composite
def spatial_analyzer_exports(draw: st.DrawFn) -> str:
    words = st.sampled_from(["A", "B", "Group1", "T1", "T2", "collection", "target", "//", "#"])
    lines = draw(
        st.lists(st.lists(st.one_of(words, cells.filter(lambda c: " " not in c)), max_size=8).map(" ".join), max_size=8)
    )
    return draw(st.sampled_from(["\n", "\r\n", "\r"])).join(lines)


@pytest.mark.slow  # ~1 s here
@FUZZ
@given(tables(["id", "target", "pose", *COLUMNS[:10]]), spatial_analyzer_exports())
def test_any_spatial_analyzer_export_is_points_or_a_4xx(joints: str, points: str) -> None:
    try:
        read_spatial_analyzer(points)
        measurements, notes = joined_campaign(joints, points, spatial_analyzer=True)
    except Exception as exc:
        _answered(exc)
        return
    _as_body(measurements, notes)


PARAMETER_COLUMNS = ["name", "value", "unit", "std_error", "nominal", "identifiable", "extra", ""]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@FUZZ
@given(tables(PARAMETER_COLUMNS), st.booleans())
def test_any_parameter_csv_is_an_import_or_a_4xx(text: str, ordered: bool) -> None:
    if ordered:  # mostly the export's own header, so the rows are read
        text = "name,value,unit,std_error,nominal,identifiable\n" + text.split("\n", 1)[-1]
    try:
        found: dict[str, Any] = parse_parameters(text)
        ParameterVersionImport.model_validate(found)
    except ValidationError:
        return
    except Exception as exc:
        _answered(exc)


@pytest.mark.parametrize("cell", ["1e400", "-1e400", "nan", "inf", "1e308"])
def test_the_edges_of_floats_in_a_campaign_are_named(cell: str) -> None:
    # Beyond the double (1e400 reads as infinity) and non-finite cells: a 400 naming the line and column; 1e308 is
    # finite, left to the schema's ranges (a 422 naming the record's field).
    text = "q1,q2,q3,q4,x,y,z\n1,2,3,4,5,6,7\n1,2,3,4," + cell + ",6,7\n"
    try:
        measurements, notes = parse_campaign(text)
    except Exception as exc:
        assert problems.lookup(exc)[0] == 400 and "line 3, column 5 (x)" in str(exc)
        return
    assert cell == "1e308"
    with pytest.raises(ValidationError):
        query = CampaignQuery(None, None, None, None, None, None, None, [])  # type: ignore[arg-type]
        payload = {"measurements": measurements, "import_notes": notes, **calibration_fields(measurements, query)}
        CalibrationCreate.model_validate(payload)
