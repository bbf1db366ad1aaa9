"""The client and the command line without the service: the progress bar's text, problems → exit codes, the
records reader, and answers a service never gives (a proxy's 502 page, a 500) from a stand-in HTTP server."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import ClassVar

import pytest

from harness.live import ROOT, free_port
from iwr_client import (
    ApiError,
    CampaignFileError,
    Client,
    JobCancelled,
    JobFailed,
    Progress,
    ServiceUnreachable,
    summary,
)
from iwr_client.cli import UsageError, calibration_exit, describe, exit_code, main
from iwr_client.progress import ProgressBar, format_eta, format_progress
from iwr_client.records import records_from_csv
from tests.cli.helpers import StandIn, serving

JOINTS = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6"]


def _problem(status: int, **extra: object) -> dict[str, object]:
    return {
        "type": "https://iwr-calibration.example/problems/x",
        "title": "T",
        "status": status,
        "detail": "d",
        **extra,
    }


# -- the progress bar ---------------------------------------------------------------------------------------------


def test_the_bar_shows_the_stage_the_percentage_the_iteration_and_the_eta() -> None:
    text = format_progress(Progress("identifying", 0.5, iteration=7, eta_seconds=3.4), width=10)
    assert text == "identifying [#####.....]  50% iteration 7, ETA 3 s"
    assert format_progress(Progress("reading", 0.0), width=4) == "reading     [....]   0%"
    assert format_progress(Progress("done", 1.0), width=4) == "done        [####] 100%"


def test_a_fraction_outside_zero_to_one_is_drawn_at_its_end() -> None:
    assert "[####] 100%" in format_progress(Progress("done", 1.2), width=4)
    assert "[....]   0%" in format_progress(Progress("x", -0.1), width=4)


@pytest.mark.parametrize(
    ("seconds", "text"), [(0.4, "ETA 0 s"), (59.4, "ETA 59 s"), (125, "ETA 2 min 05 s"), (3720, "ETA 1 h 02 min")]
)
def test_the_eta_reads_in_seconds_minutes_or_hours(seconds: float, text: str) -> None:
    assert format_eta(seconds) == text


def test_on_a_terminal_the_bar_is_redrawn_in_place_and_blanks_what_a_shorter_line_leaves() -> None:
    stream = io.StringIO()
    bar = ProgressBar(stream, tty=True)
    bar(Progress("identifying", 0.25, iteration=3, eta_seconds=10))
    bar(Progress("done", 1.0))
    bar.close()
    first, second = stream.getvalue().split("\r")[1:]
    assert "\n" not in first and second.endswith("\n")
    assert len(second.rstrip("\n")) == len(first)  # padded: no tail of the longer first line stays on screen
    assert second.startswith("done")


def test_elsewhere_the_bar_writes_a_plain_line_per_stage_and_tenth() -> None:
    stream = io.StringIO()
    bar = ProgressBar(stream, tty=False)
    for fraction in (0.0, 0.01, 0.02, 0.15, 0.16, 1.0):
        bar(Progress("identifying", fraction))
    bar(Progress("storing", 1.0))
    bar.close()
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    assert [line.split()[0] for line in lines] == ["identifying"] * 3 + ["storing"]
    assert [line.split()[-1] for line in lines] == ["0%", "15%", "100%", "100%"]


# -- errors and exit codes ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("error", "code"),
    [
        (ApiError(_problem(404)), 3),
        (ApiError(_problem(422)), 3),
        (ApiError(_problem(409, calibration_id="c")), 3),
        (ApiError(_problem(500)), 4),
        (ApiError(_problem(503)), 4),
        (JobFailed({"id": "j", "error": _problem(422)}), 3),
        (JobFailed({"id": "j", "error": None}), 4),
        (JobCancelled({"id": "j"}), 1),
        (ServiceUnreachable("http://x", "refused"), 4),
        (UsageError("no"), 2),
        (CampaignFileError("no"), 2),
    ],
    ids=lambda v: type(v).__name__ if isinstance(v, BaseException) else str(v),
)
def test_each_error_ends_the_command_with_its_exit_code(error: BaseException, code: int) -> None:
    assert exit_code(error) == code


def test_an_unexpected_error_is_not_swallowed_into_an_exit_code() -> None:
    with pytest.raises(KeyError):
        exit_code(KeyError("bug"))


def test_a_problem_keeps_its_members_and_its_extensions() -> None:
    error = ApiError(_problem(409, calibration_id="c1", current_version=3))
    assert (error.status, error.title, error.detail, error.type) == (409, "T", "d", _problem(0)["type"])
    assert error.extensions == {"calibration_id": "c1", "current_version": 3}
    issues = [{"loc": ["body", "name"], "field": "name", "msg": "too long"}]
    assert describe(ApiError(_problem(422, errors=issues))).splitlines() == [
        "iwr: error: 422 T: d",
        f"  ({_problem(0)['type']})",
        "  name: too long",
    ]


@pytest.mark.parametrize(
    ("status", "applied", "asked", "code"),
    [
        ("succeeded", True, True, 0),
        ("succeeded", False, True, 1),
        ("succeeded", False, False, 0),
        ("failed", False, True, 1),
    ],
)
def test_a_calibration_that_failed_or_was_not_applied_as_asked_exits_1(
    status: str, applied: bool, asked: bool, code: int
) -> None:
    assert calibration_exit({"status": status, "applied": applied}, asked_to_apply=asked) == code


# -- the records reader -------------------------------------------------------------------------------------------


def test_the_campaign_file_reads_as_records_in_the_robots_joint_order() -> None:
    records = records_from_csv((ROOT / "examples" / "campaign.csv").read_text(), JOINTS)
    assert len(records) == 40
    first = records[0]
    assert first["joints"][0] == pytest.approx(169.566205) and len(first["joints"]) == 10
    assert first["position"] == pytest.approx([109.3516, -2254.2100, -2687.9233])
    assert len(first["orientation"]) == 4


def test_columns_in_another_order_and_optional_ones_are_read_by_name() -> None:
    text = "x,y,z,b,a,sigma_mm\n1,2,3,20,10,0.01\n\n"
    assert records_from_csv(text, ["a", "b"]) == [
        {"joints": [10.0, 20.0], "position": [1.0, 2.0, 3.0], "sigma_mm": 0.01}
    ]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("a,q2\n1,2\n", "the header lacks x, y, z"),
        ("a,x,y,z\n1,2,3\n", "row 2 has"),
        ("a,x,y,z\n1,2,3,4,5\n", "row 2 has"),
        ("a,x,y,z\n1,two,3,4\n", "row 2, column x: 'two' is not a number"),
        ("a,x,y,z\nnan,1,3,4\n", "not a finite number"),
        ("a,x,y,z\n", "no records"),
    ],
)
def test_a_malformed_records_file_names_what_is_wrong(text: str, message: str) -> None:
    with pytest.raises(CampaignFileError, match=message):
        records_from_csv(text, ["a"])


# -- answers no service gives, from a stand-in server -------------------------------------------------------------


RUNNING = {"id": "j2", "status": "running", "progress": {"stage": "identifying", "fraction": 0.3}}


class _Canned(StandIn):
    """Answers each path with a canned status and body: a proxy's HTML 502, a service's 500 problem."""

    ANSWERS: ClassVar[dict[str, tuple[int, str, bytes]]] = {
        "/v1/robots": (502, "text/html", b"<html><body>Bad Gateway</body></html>"),
        "/v1/jobs/j1": (500, "application/problem+json", json.dumps(_problem(500)).encode()),
        "/v1/jobs/j2": (200, "application/json", json.dumps(RUNNING).encode()),
    }
    DELETED: ClassVar[list[str]] = []

    def do_DELETE(self) -> None:
        self.DELETED.append(self.path)
        self.do_GET()

    def do_GET(self) -> None:
        self.answer(*self.ANSWERS.get(self.path.split("?")[0], (404, "text/plain", b"no")))


@pytest.fixture(scope="module")
def stand_in() -> Iterator[str]:
    with serving(_Canned) as url:
        yield url


def test_an_answer_that_is_not_a_problem_becomes_one_with_its_status(stand_in: str) -> None:
    with pytest.raises(ApiError) as caught:
        Client(stand_in).robots()
    assert caught.value.status == 502 and "Bad Gateway" in caught.value.detail
    assert exit_code(caught.value) == 4


def test_a_5xx_problem_exits_4_and_prints_its_detail(stand_in: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--url", stand_in, "robots", "list"]) == 4
    assert "502" in capsys.readouterr().err
    with pytest.raises(ApiError) as caught:
        Client(stand_in).wait("j1")
    assert caught.value.status == 500


def test_interrupted_while_waiting_the_client_cancels_the_job(stand_in: str) -> None:
    """A workflow method never hands its job's id back: Ctrl-C during the wait cancels the job, then goes on."""

    def interrupt(progress: Progress) -> None:
        assert progress == Progress("identifying", 0.3)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        Client(stand_in).result("j2", interrupt)
    assert _Canned.DELETED == ["/v1/jobs/j2"]


def test_options_go_before_or_after_the_command(stand_in: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "list", "--url", stand_in, "--json"]) == 4
    assert capsys.readouterr().out == ""  # --json: nothing but documents on stdout, and there is none


def test_usage_errors_exit_2(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["design", "r1"]) == 2  # neither --count nor --target-rms-mm
    assert main(["calibrate", "r1", str(tmp_path / "missing.csv")]) == 2
    assert main(["frobnicate"]) == 2
    assert "cannot read" in capsys.readouterr().err


def test_a_design_needs_a_count_or_a_target() -> None:
    with pytest.raises(ValueError, match="count or target"):
        Client().design("r1")


def test_the_client_runs_on_a_bare_python_and_an_unreachable_service_exits_4() -> None:
    """The base interpreter, isolated (-I) and without site-packages (-S): not one third-party package exists,
    so the command's imports are the standard library's; nothing listens on the port."""
    interpreter = Path(sys.base_prefix) / "bin" / f"python{sys.version_info.major}.{sys.version_info.minor}"
    start = f"import sys, runpy; sys.path.insert(0, {str(ROOT)!r}); sys.argv[0] = 'iwr'; "
    start += "runpy.run_module('iwr_client', run_name='__main__')"
    url = f"http://127.0.0.1:{free_port()}"
    run = subprocess.run(
        [str(interpreter), "-I", "-S", "-c", start, "--url", url, "robots", "list"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert run.returncode == 4, run.stderr
    assert f"{url} is unreachable" in run.stderr and run.stdout == ""


def test_a_checks_summary_names_the_verdict_the_statistic_the_explanation_and_what_to_do() -> None:
    check = {
        "id": "c1",
        "verdict": "changed",
        "version": 2,
        "measurements": 8,
        "statistic": {"chi2": 93.2, "threshold": 66.2, "alpha": 0.01, "p_value": 1.2e-5},
        "explanation": {
            "name": "leg3.offset",
            "parameters": [{"name": "leg3.offset", "change": -0.1012, "std_error": 0.011, "unit": "mm"}],
        },
        "recommendation": {"message": "re-fit leg3.offset from 12 designed poses"},
        "warnings": [{"message": "40.0 °C is 5.0 °C above the calibrated 20-35 °C"}],
    }
    lines = summary.check_summary(check).splitlines()
    assert lines[0] == "check c1: changed (version 2, 8 records; chi2 93.2 against 66.2 at alpha 0.01, p = 1.2e-05)"
    assert lines[1] == "  explained by leg3.offset: leg3.offset -0.1012 ± 0.0110 mm"
    assert lines[2] == "  to do: re-fit leg3.offset from 12 designed poses"
    assert lines[3] == "  warning: 40.0 °C is 5.0 °C above the calibrated 20-35 °C"


def test_the_history_table_has_a_row_per_event_and_dashes_for_what_was_not_measured() -> None:
    events = [
        {"at": "2026-12-01T08:00:00Z", "kind": "calibration", "outcome": "succeeded, applied", "version": 2,
         "rms_mm": 0.0213, "predicted_mm": 0.0151},
        {"at": "2026-12-05T08:00:00Z", "kind": "check", "outcome": "fine", "version": 2, "rms_mm": None,
         "predicted_mm": 0.03},
    ]  # fmt: skip
    lines = summary.history_table(events).splitlines()
    assert lines[0].split() == ["at", "kind", "outcome", "version", "measured", "expected"]
    assert lines[1].split() == ["2026-12-01", "08:00:00", "calibration", "succeeded,", "applied", "2", "0.0213", "mm",
                                "0.0151", "mm"]  # fmt: skip
    assert lines[2].split() == ["2026-12-05", "08:00:00", "check", "fine", "2", "–", "0.0300", "mm"]
    assert summary.history_table([]) == "no calibrations or checks yet"


class _Recording(StandIn):
    """Records each POST (path with its query, content type, body) and answers a failed calibration."""

    SEEN: ClassVar[list[tuple[str, str, bytes]]] = []

    def do_POST(self) -> None:
        body = self.rfile.read(int(self.headers.get("Content-Length", "0")))
        self.SEEN.append((self.path, self.headers.get("Content-Type", ""), body))
        self.answer_json(201, {"id": "c1", "status": "failed", "reason": "canned", "applied": False})


def test_calibrate_sends_the_column_map_and_the_joint_unit_with_the_file_as_it_is(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 45: `iwr calibrate ROBOT FILE --columns 'Achse 1=joint_1,…' --joint-unit rad`; the file's bytes go
    unchanged (a Windows-1252 export is decoded by the service, which names the encoding)."""
    with serving(_Recording) as url:
        campaign = tmp_path / "AT960.csv"
        raw = "Achse 1;X [mm];Temperature [°C]\n1,5;2,0;21,3\n".encode("cp1252")
        campaign.write_bytes(raw)
        code = main(
            [
                "--url",
                url,
                "calibrate",
                "r1",
                str(campaign),
                "--sync",
                "--columns",
                "Achse 1=joint_1",
                "--joint-unit",
                "rad",
            ]
        )
        assert code == 1  # the canned calibration failed
        path, content_type, body = _Recording.SEEN[-1]
        assert path.startswith("/v1/robots/r1/calibrations?") and content_type.startswith("text/csv")
        assert "columns=Achse+1%3Djoint_1" in path or "columns=Achse%201%3Djoint_1" in path, path
        assert "joint_unit=rad" in path and body == raw
        with pytest.raises(ValueError, match="records are the API's own"):
            Client(url).calibrate("r1", [{"joints": [0.0], "position": [0.0, 0.0, 0.0]}], columns="A1=q1")
    capsys.readouterr()
