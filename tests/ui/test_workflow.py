"""The calibration workflow in /ui driven by clicks and file uploads only, each outcome checked against the API:
a robot created, a campaign uploaded and calibrated as a job, its result page showing the stored numbers; a
failed and a refused calibration showing their reasons (and a forced apply of the refused one); a robot from a
DH table (with its base and tool), a pose design with its CSV, a validation, a 401 said in words, and a
Windows-1252 tracker file read through a column map."""

from __future__ import annotations

import csv
import json
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import pytest
from playwright.sync_api import expect
from scipy.spatial.transform import Rotation

from tests.models.test_urdf_hostile import joint, urdf
from tests.ui.conftest import PAGE_WAIT_MS, screenshot, watched_page

pytestmark = pytest.mark.slow  # a browser against the live server of tests/ui: ~10 s here once it runs
ROOT = Path(__file__).resolve().parents[2]
CAMPAIGN = ROOT / "examples" / "campaign.csv"  # 40 full-pose records of a simulated IWR, mm and degrees
RECORDS = 40


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[Any]:
    yield from watched_page(browser, server, viewport={"width": 1200, "height": 900}, accept_downloads=True)


def _ready(page: Any, pattern: str) -> str:
    """Waits until the page drawn is one whose fragment matches `pattern`; returns the fragment."""
    # Attribute waits, not wait_for_function: the page's Content-Security-Policy forbids eval, which that uses.
    expect(page.locator("body")).to_have_attribute("data-ready", re.compile(pattern), timeout=PAGE_WAIT_MS)
    fragment: str = page.evaluate("document.body.dataset.ready")
    return fragment


def _robot_form(page: Any, server: str, name: str, source: str | None = None) -> None:
    """The new-robot form, the robot named `name` and described by `source` (the label of its choice: "A DH / MDH
    table", "A URDF file"; None: the IWR, the form's default)."""
    page.goto(f"{server}/ui#/")
    _ready(page, "^#/$")
    page.get_by_label("Name").fill(name)
    if source is not None:
        page.get_by_label(source).check()


def _create(page: Any) -> str:
    """Creates the robot the form describes: its id, once its page is drawn."""
    page.get_by_role("button", name="Create the robot").click()
    return _ready(page, "^#/robots/[0-9a-f-]+$").split("/")[-1]


def _create_iwr(page: Any, server: str, name: str) -> str:
    _robot_form(page, server, name)
    return _create(page)


def _calibrate(page: Any, campaign: Path, *, noise_mm: float | None = None) -> str:
    page.get_by_role("link", name="2. Calibrate from a campaign").click()
    _ready(page, "/calibrate$")
    page.set_input_files("#campaign-file", str(campaign))
    page.wait_for_selector("#preview-table")
    if noise_mm is not None:
        page.get_by_label("Instrument σ, position (mm)").fill(str(noise_mm))
        page.get_by_label("σ, orientation (deg)").fill(str(noise_mm / 10))
    page.get_by_role("button", name="Calibrate").click()
    return _ready(page, "^#/calibrations/[0-9a-f-]+$").split("/")[-1]


def test_a_whole_calibration_by_clicks(page: Any, server: str) -> None:
    robot_id = _create_iwr(page, server, "cell-browser")
    page.get_by_role("link", name="2. Calibrate from a campaign").click()
    _ready(page, "/calibrate$")
    page.set_input_files("#campaign-file", str(CAMPAIGN))
    page.wait_for_selector("#preview-table")
    header = next(csv.reader(CAMPAIGN.read_text().splitlines()))
    assert page.locator("#preview-table thead th").count() == len(header)
    assert page.locator("#preview-table .role-ignored").count() == 0  # every column is one the service reads
    assert f"{RECORDS} records" in page.locator("#preview-notes").inner_text()
    screenshot(page, "campaign-preview")
    page.get_by_role("button", name="Calibrate").click()
    calibration_id = _ready(page, "^#/calibrations/[0-9a-f-]+$").split("/")[-1]
    screenshot(page, "calibration-result")

    stored = httpx.get(f"{server}/v1/calibrations/{calibration_id}").json()
    assert stored["robot_id"] == robot_id and stored["status"] == "succeeded" and stored["applied"]
    assert stored["measurements"] == RECORDS
    after = page.locator('[data-key="residuals.after.rms_mm"]')
    assert float(after.get_attribute("data-value")) == stored["residuals"]["after"]["rms_mm"]
    shown = float(after.inner_text().split()[0])  # to 4 significant digits
    assert shown == pytest.approx(stored["residuals"]["after"]["rms_mm"], rel=1e-3)
    before = page.locator('[data-key="residuals.before.rms_mm"]').get_attribute("data-value")
    assert float(before) == stored["residuals"]["before"]["rms_mm"]
    assert "Applied" in page.locator("#verdict").inner_text()
    assert f"version {stored['parameter_version']}" in page.locator("#verdict").inner_text()
    # One bar per record before and one after; one row per parameter and per check, as stored.
    assert page.locator("#residual-plot > rect.bar").count() == 2 * RECORDS
    assert page.locator("#parameters tbody tr").count() == len(stored["parameters"])
    assert page.locator("#checks tbody tr").count() == len(stored["checks"])
    calibrations = httpx.get(f"{server}/v1/robots/{robot_id}/calibrations").json()
    assert [c["id"] for c in calibrations] == [calibration_id]
    # The exports download what the API serves.
    with page.expect_download() as download:
        page.locator("#export-csv").click()
    exported = Path(download.value.path()).read_text()
    assert (
        exported
        == httpx.get(
            f"{server}/v1/robots/{robot_id}/parameters",
            params={"version": stored["parameter_version"], "format": "csv"},
        ).text
    )
    # The job is listed, and its link leads back to this result.
    page.get_by_role("link", name="Jobs").click()
    _ready(page, "^#/jobs$")
    row = page.locator("#jobs tbody tr", has=page.locator(f'a[href="#/robots/{robot_id}"]'))
    row.get_by_role("button", name="result").click()
    _ready(page, f"^#/calibrations/{calibration_id}$")
    # The report itself (its numbers are the API's) is test_pages' subject: rendering it costs seconds.
    report = page.get_by_role("link", name="Report (HTML)")
    assert report.get_attribute("href") == f"#/calibrations/{calibration_id}/report"


def _in_radians(tmp_path: Path) -> Path:
    """The example campaign with its revolute joints q3, q4 in radians: the service's diagnosis refuses it."""
    rows = list(csv.reader(CAMPAIGN.read_text().splitlines()))
    for row in rows[1:]:
        row[2], row[3] = (str(math.radians(float(v))) for v in row[2:4])
    path = tmp_path / "campaign-radians.csv"
    with path.open("w", newline="") as f:
        csv.writer(f).writerows(rows)
    return path


def test_a_failed_calibration_shows_its_reason(page: Any, server: str, tmp_path: Path) -> None:
    _create_iwr(page, server, "cell-radians")
    calibration_id = _calibrate(page, _in_radians(tmp_path))
    page.wait_for_selector("#verdict.failed")
    screenshot(page, "calibration-failed")
    stored = httpx.get(f"{server}/v1/calibrations/{calibration_id}").json()
    assert stored["status"] == "failed" and not stored["applied"]
    assert page.locator("#failure-reason").inner_text() == stored["reason"]
    assert "radians" in stored["reason"]
    diagnosis = stored["diagnoses"][0]
    assert f"{diagnosis['finding']} (blocking): {diagnosis['message']}" in page.locator("#diagnoses").inner_text()
    assert page.locator("#parameters").count() == 0  # no fit was run: no estimates to show


def test_a_campaign_refused_before_any_fit_says_why(page: Any, server: str, tmp_path: Path) -> None:
    robot_id = _create_iwr(page, server, "cell-short-leg")
    lines = CAMPAIGN.read_text().splitlines()
    cells = lines[1].split(",")
    cells[4] = "5"  # leg l1 at 5 mm: outside its stroke, so the job fails before fitting and stores nothing
    path = tmp_path / "campaign-short-leg.csv"
    path.write_text("\n".join([lines[0], ",".join(cells), *lines[2:]]) + "\n")
    page.get_by_role("link", name="2. Calibrate from a campaign").click()
    _ready(page, "/calibrate$")
    page.set_input_files("#campaign-file", str(path))
    page.get_by_role("button", name="Calibrate").click()
    refusal = page.locator("#calibration-refused")
    refusal.wait_for(timeout=PAGE_WAIT_MS)
    jobs = httpx.get(f"{server}/v1/jobs", params={"robot_id": robot_id}).json()
    assert jobs[0]["status"] == "failed"
    assert jobs[0]["error"]["detail"] in refusal.inner_text() and "l1" in refusal.inner_text()
    assert httpx.get(f"{server}/v1/robots/{robot_id}/calibrations").json() == []


def test_a_refused_calibration_says_why_and_can_be_forced(page: Any, server: str, tmp_path: Path) -> None:
    robot_id = _create_iwr(page, server, "cell-noise")
    # A σ stated ten times too small is said (the noise check fails) but holds nothing back: applied.
    applied_id = _calibrate(page, CAMPAIGN, noise_mm=0.0025)
    page.wait_for_selector("#verdict.applied")
    applied = httpx.get(f"{server}/v1/calibrations/{applied_id}").json()
    assert [c["name"] for c in applied["checks"] if not c["passed"]] == ["noise"] and applied["applied"]
    # A third of the campaign predicts worse than the version it starts from: stored, not applied.
    lines = CAMPAIGN.read_text().splitlines()
    fewer = tmp_path / "campaign-fewer.csv"
    fewer.write_text("\n".join(lines[: 1 + RECORDS // 3]) + "\n")
    page.get_by_role("link", name="← cell-noise").click()
    _ready(page, "^#/robots/[0-9a-f-]+$")
    refused_id = _calibrate(page, fewer, noise_mm=0.0025)
    page.wait_for_selector("#verdict.not-applied")
    refused = httpx.get(f"{server}/v1/calibrations/{refused_id}").json()
    assert refused["status"] == "succeeded" and not refused["applied"]
    assert page.locator("#not-applied-reason").inner_text() == refused["not_applied_reason"]
    failed = [c["name"] for c in refused["checks"] if not c["passed"] and c["blocks_apply"]]
    assert "accuracy" in failed and "noise" not in failed  # the noise check never blocks
    screenshot(page, "calibration-not-applied")
    page.get_by_role("button", name="Force apply").click()
    expect(page).not_to_have_url(re.compile(re.escape(f"#/calibrations/{refused_id}") + "$"))
    forced_id = _ready(page, "^#/calibrations/[0-9a-f-]+$").split("/")[-1]
    page.wait_for_selector("#verdict.applied")
    assert forced_id != refused_id
    forced = httpx.get(f"{server}/v1/calibrations/{forced_id}").json()
    assert forced["applied"] and forced["forced"] and forced["noise"] == refused["noise"]
    assert httpx.get(f"{server}/v1/robots/{robot_id}").json()["parameter_version"] == forced["parameter_version"]
    # And back: the nominal version restored from the robot's version list.
    page.get_by_role("link", name="← cell-noise").click()
    _ready(page, "^#/robots/[0-9a-f-]+$")
    page.get_by_role("button", name="restore 1").click()
    # The page redrawn with the restore (a fourth row, current): the forced version's row was current before it.
    expect(page.locator("#versions tbody tr")).to_have_count(4)
    expect(page.locator("#versions tbody tr:last-child b")).to_have_text("current")
    versions = httpx.get(f"{server}/v1/robots/{robot_id}/parameter-versions").json()
    assert (versions[-1]["provenance"], versions[-1]["restored_from"], versions[-1]["current"]) == ("restore", 1, True)


# A spreadsheet's copy: joint, θ, d, a, α, range from, range to; tabs between cells.
DH_ROWS = (
    "revolute\t0\t400\t25\t-90\t-170\t170\nrevolute\t-90\t0\t455\t0\t-100\t150\nrevolute\t0\t0\t35\t-90\t-210\t66\n"
)


def test_a_robot_from_a_pasted_dh_table(page: Any, server: str) -> None:
    _robot_form(page, server, "arm-dh", "A DH / MDH table")
    page.get_by_label("Or paste rows from a spreadsheet").fill(DH_ROWS)
    page.get_by_role("button", name="Fill the table from the pasted rows").click()
    assert page.locator("#dh-table tbody tr").count() == 3
    screenshot(page, "robot-dh")
    robot_id = _create(page)
    robot = httpx.get(f"{server}/v1/robots/{robot_id}").json()
    assert robot["model"] == "custom" and robot["joint_names"] == ["q1", "q2", "q3"]
    links = robot["structure"]["stages"][0]["links"]
    stored = [[k["theta"], k["d"], k["a"], k["alpha"], *k["range"]] for k in links]
    typed = [[float(v) for v in line.split("\t")[1:]] for line in DH_ROWS.splitlines()]
    assert [v for row in stored for v in row] == pytest.approx([v for row in typed for v in row], abs=1e-9)


def test_a_robot_from_a_urdf_file(page: Any, server: str, tmp_path: Path) -> None:
    # Three revolute joints from l0 to l3, and a camera link hanging off l1 that is not part of the arm.
    links = ["l0", "l1", "l2", "l3", "camera"]
    joints = [joint(f"j{i}", f"l{i}", f"l{i + 1}") for i in range(3)] + [joint("mount", "l1", "camera", "fixed")]
    path = tmp_path / "arm.urdf"
    path.write_text(urdf(links, joints))
    _robot_form(page, server, "arm-urdf", "A URDF file")
    page.set_input_files("#urdf-file", str(path))
    expect(page.locator("#urdf-tip option")).to_have_count(5)
    assert page.locator("#urdf-base").input_value() == "l0"  # the root, offered first
    page.select_option("#urdf-tip", "l3")
    robot_id = _create(page)
    robot = httpx.get(f"{server}/v1/robots/{robot_id}").json()
    assert robot["model"] == "custom" and robot["joint_names"] == ["q1", "q2", "q3"]


def test_a_wrong_table_is_refused_in_words(page: Any, server: str) -> None:
    _robot_form(page, server, "arm-wrong", "A DH / MDH table")
    page.locator("#dh-table tbody tr").first.locator('[data-key="a"]').fill("twelve")
    page.get_by_role("button", name="Create the robot").click()
    text = page.locator("#create-error").inner_text()
    assert "422" in text and "stages[0].links[0].a" in text and "[object Object]" not in text


def test_pose_design_table_plots_and_pendant_csv(page: Any, server: str) -> None:
    _create_iwr(page, server, "cell-design")
    page.get_by_role("link", name="1. Design poses").click()
    _ready(page, "/design$")
    # The criteria are the service's list, not a copy in the page (GET /v1/design-criteria)
    offered = page.locator("#design-criterion option").evaluate_all("(os) => os.map((o) => o.value)")
    assert offered == [c["name"] for c in httpx.get(f"{server}/v1/design-criteria").json()]
    page.get_by_label("Poses", exact=True).fill("12")
    page.get_by_label("Candidate poses sampled").fill("300")
    page.get_by_role("button", name="Design the poses").click()
    page.wait_for_selector("#design-poses", timeout=30_000)
    assert page.locator("#design-poses tbody tr").count() == 12
    assert page.locator("#design-coverage circle.point").count() == 12 * 10  # every joint of every pose
    assert page.locator("#design-side circle.point").count() == 12
    screenshot(page, "pose-design")
    with page.expect_download() as download:
        page.get_by_role("button", name="Download the poses as CSV (for the pendant)").click()
    rows = list(csv.reader(Path(download.value.path()).read_text().splitlines()))
    designs = httpx.get(f"{server}/v1/robots/{_robot_of(page)}/pose-designs").json()
    design = httpx.get(f"{server}/v1/pose-designs/{designs[0]['id']}").json()
    assert rows[0] == ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6"]
    written = [float(v) for r in rows[1:] for v in r]
    assert written == pytest.approx([v for pose in design["poses"] for v in pose], abs=1e-6)


def _robot_of(page: Any) -> str:
    found = re.search(r"#/robots/([0-9a-f-]+)", page.url)
    assert found
    return found.group(1)


def _as_a_controller_writes_it() -> tuple[str, str]:
    """The campaign under a cell's own column names (Achse 1…4, Bein 1…6) with its wrist angles (q3, q4) in
    radians, as a controller exports it; and the column map that names them."""
    rows = list(csv.reader(CAMPAIGN.read_text().splitlines()))
    names = [f"Achse {k + 1}" for k in range(4)] + [f"Bein {k}" for k in range(1, 7)]
    mapping = ",".join(f"{name}={joint}" for name, joint in zip(names, rows[0][:10], strict=True))
    lines = [",".join([*names, *rows[0][10:]])]
    for row in rows[1:]:
        lines.append(",".join([*row[:2], *(repr(math.radians(float(v))) for v in row[2:4]), *row[4:]]))
    return "\n".join(lines) + "\n", mapping


def test_validation_of_the_current_version(page: Any, server: str) -> None:
    """The file is sent as it is with the column map and the joints' unit, as a calibration's is: the answer is
    the JSON form's for the campaign's records."""
    robot_id = _create_iwr(page, server, "cell-validate")
    page.get_by_role("link", name="3. Validate").click()
    _ready(page, "/validate$")
    text, mapping = _as_a_controller_writes_it()
    # Dropped on the zone this time (the campaign test uses the file picker).
    transfer = page.evaluate_handle(
        """text => { const t = new DataTransfer(); t.items.add(new File([text], "validation.csv")); return t; }""",
        text,
    )
    page.dispatch_event("#validation-file-zone", "drop", {"dataTransfer": transfer})
    page.wait_for_selector("#validation-preview table")
    page.fill("#validation-column-map", mapping)
    page.select_option("#validation-joint-unit", "rad")
    page.get_by_role("button", name="Validate").click()
    page.wait_for_selector("#validation-results")
    screenshot(page, "validation")
    validations = httpx.get(f"{server}/v1/robots/{robot_id}/validations").json()
    assert len(validations) == 1 and validations[0]["measurements"] == RECORDS
    rms = validations[0]["results"][0]["position_mm"]["rms"]
    shown = page.locator("#validation-results tbody tr td:nth-child(2)").inner_text()
    assert float(shown) == pytest.approx(rms, rel=1e-3)
    notes = page.locator("#validation-notes").inner_text()
    assert "achse_1 → q1" in notes and "q3 is in rad" in notes
    records = list(csv.DictReader(CAMPAIGN.read_text().splitlines()))
    as_json = httpx.post(
        f"{server}/v1/robots/{robot_id}/validations",
        json={
            "measurements": [
                {
                    "joints": [float(r[j]) for j in list(r)[:10]],
                    "position": [float(r[k]) for k in "xyz"],
                    "orientation": [float(r[k]) for k in ("qw", "qx", "qy", "qz")],
                }
                for r in records
            ]
        },
    ).json()
    assert rms == pytest.approx(as_json["results"][0]["position_mm"]["rms"], abs=1e-9)


def test_a_401_is_said_in_words(page: Any, server: str) -> None:
    # The service of these tests has no keys; the 401 a keyed service answers is replayed for the robot list.
    problem = {"type": "about:blank", "title": "Unauthorized", "status": 401, "detail": "send a valid API key"}
    page.route(
        f"{server}/v1/robots",
        lambda route: route.fulfill(status=401, content_type="application/problem+json", body=json.dumps(problem)),
    )
    page.goto(f"{server}/ui#/")
    _ready(page, "^error$")
    text = page.locator("#error").inner_text()
    assert "401" in text and "API key" in text


def test_a_running_job_is_cancelled_and_listed(page: Any, server: str) -> None:
    robot_id = _create_iwr(page, server, "cell-cancel")
    page.get_by_role("link", name="1. Design poses").click()
    _ready(page, "/design$")
    page.get_by_label("Poses", exact=True).fill("40")
    page.get_by_label("Candidate poses sampled").fill("20000")  # seconds of work: time to cancel it
    page.get_by_role("button", name="Design the poses").click()
    page.wait_for_selector("#job-status .status-running", timeout=PAGE_WAIT_MS)
    page.get_by_role("button", name="Cancel").click()
    page.wait_for_selector("#job-cancelled", timeout=30_000)
    jobs = httpx.get(f"{server}/v1/jobs", params={"robot_id": robot_id}).json()
    assert [(j["kind"], j["status"]) for j in jobs] == [("pose_design", "cancelled")]
    assert httpx.get(f"{server}/v1/robots/{robot_id}/pose-designs").json() == []
    page.get_by_role("link", name="Jobs").click()
    _ready(page, "^#/jobs$")
    row = page.locator("#jobs tbody tr", has=page.locator(f'a[href="#/robots/{robot_id}"]'))
    assert row.locator(".status-cancelled").inner_text() == "cancelled"
    screenshot(page, "jobs-cancelled")


def test_a_dh_robot_takes_its_base_and_tool_and_the_last_link_stays_as_typed(page: Any, server: str) -> None:
    """Issue 45: the DH form had no tool, so a tracker reflector's 95 mm went into the last link (82.3 → 177.1 mm)
    and every export carried it. The tool (and the base) are now fields of their own, into the document's."""
    _robot_form(page, server, "arm-dh-tool", "A DH / MDH table")
    page.get_by_label("Or paste rows from a spreadsheet").fill(DH_ROWS)
    page.get_by_role("button", name="Fill the table from the pasted rows").click()
    typed_base = {"x": "1200", "y": "-350,5", "z": "0", "rz": "30", "ry": "0", "rx": "0"}  # a decimal comma too
    typed_tool = {"x": "0", "y": "0", "z": "95", "rz": "10", "ry": "-20", "rx": "180"}
    for what, typed in (("Base", typed_base), ("Tool", typed_tool)):
        for key, value in typed.items():
            unit = "mm" if key in "xyz" else "deg"
            page.get_by_label(f"{what} {key} ({unit})", exact=True).fill(value)
    screenshot(page, "robot-dh-base-tool")
    robot_id = _create(page)
    robot = httpx.get(f"{server}/v1/robots/{robot_id}").json()
    document = robot["structure"]
    for pose, typed in ((document["base"], typed_base), (document["tool"], typed_tool)):
        numbers = {k: float(v.replace(",", ".")) for k, v in typed.items()}
        assert pose["position"] == pytest.approx([numbers["x"], numbers["y"], numbers["z"]], abs=1e-9)
        # The independent truth: scipy's intrinsic Z-Y-X rotation, as [w, x, y, z] up to the quaternion's sign.
        x, y, z, w = Rotation.from_euler("ZYX", [numbers["rz"], numbers["ry"], numbers["rx"]], degrees=True).as_quat()
        expected = np.array([w, x, y, z])
        got = np.array(pose["orientation"])
        assert min(np.abs(got - expected).max(), np.abs(got + expected).max()) < 1e-9
    assert robot["tool"]["position"] == pytest.approx([0.0, 0.0, 95.0], abs=1e-9)
    links = document["stages"][0]["links"]
    last = [links[-1]["theta"], links[-1]["d"], links[-1]["a"], links[-1]["alpha"], *links[-1]["range"]]
    assert last == pytest.approx([float(v) for v in DH_ROWS.splitlines()[-1].split("\t")[1:]], abs=1e-9)


def test_a_windows_1252_tracker_file_with_a_column_map_calibrates_by_clicks(
    page: Any, server: str, tmp_path: Path
) -> None:
    """Issue 45: the campaign's bytes go as they are (a Windows-1252 export with °C in its header) and a column map
    says which of a controller's columns is which joint."""
    rows = list(csv.reader(CAMPAIGN.read_text().splitlines()))
    header = [f"Achse {k + 1}" for k in range(4)] + [f"Bein {k}" for k in range(1, 7)]
    header += ["X [mm]", "Y [mm]", "Z [mm]", "qw", "qx", "qy", "qz", "Temperature [°C]"]
    lines = [";".join(header)] + [";".join([*(c.replace(".", ",") for c in row), "21,5"]) for row in rows[1:]]
    path = tmp_path / "AT960 Export.csv"
    path.write_bytes("\r\n".join(lines).encode("cp1252"))
    _create_iwr(page, server, "cell-cp1252")
    page.get_by_role("link", name="2. Calibrate from a campaign").click()
    _ready(page, "/calibrate$")
    page.set_input_files("#campaign-file", str(path))
    page.wait_for_selector("#preview-table")
    assert "Temperature [°C]" not in page.locator("#preview-table thead").inner_text()  # the unit is shown apart
    assert "°c" in page.locator("#preview-table thead").inner_text().lower()  # decoded, not a replacement sign
    mapping = ",".join([f"Achse {k + 1}=q{k + 1}" for k in range(4)] + [f"Bein {k}=l{k}" for k in range(1, 7)])
    page.get_by_label("Column map (file column = joint or coordinate)").fill(mapping)
    page.get_by_role("button", name="Calibrate").click()
    calibration_id = _ready(page, "^#/calibrations/[0-9a-f-]+$").split("/")[-1]
    stored = httpx.get(f"{server}/v1/calibrations/{calibration_id}").json()
    assert stored["status"] == "succeeded" and stored["measurements"] == RECORDS
    notes = " ".join(stored["notes"])
    assert "Windows-1252" in notes and "achse_1 → q1" in notes and "decimal commas" in notes


def test_a_xacro_file_is_named_with_its_command(page: Any, server: str, tmp_path: Path) -> None:
    """Issue 45: a xacro chosen as the URDF offered no link and the service then answered "no link ''"."""
    path = tmp_path / "irb2400_macro.xacro"
    path.write_text(
        '<?xml version="1.0"?>\n<robot xmlns:xacro="http://ros.org/wiki/xacro">\n'
        '<xacro:macro name="abb_irb2400" params="prefix">\n  <link name="${prefix}base_link"/>\n'
        "</xacro:macro>\n</robot>\n"
    )
    _robot_form(page, server, "arm-xacro", "A URDF file")
    page.set_input_files("#urdf-file", str(path))
    expect(page.locator("#urdf-info")).to_contain_text("xacro")
    assert "xacro robot.urdf.xacro > robot.urdf" in page.locator("#urdf-info").inner_text()
    page.get_by_role("button", name="Create the robot").click()
    text = page.locator("#create-error").inner_text()
    assert "422" in text and "ros2 run xacro" in text and "no link" not in text


def test_a_file_of_several_points_a_row_is_previewed_with_its_units(page: Any, server: str) -> None:
    """The TIAGo mocap file as published (tests/data/real/tiago_mocap): the preview says which point each column
    is and reads marker_std_mm as σ; the validation form offers the length unit its metres need."""
    _create_iwr(page, server, "cell-mocap")
    page.get_by_role("link", name="3. Validate").click()
    _ready(page, "/validate$")
    text = (ROOT / "tests" / "data" / "real" / "tiago_mocap" / "qualisys_2021-11-26_static_postures.csv").read_text()
    transfer = page.evaluate_handle(
        """text => { const t = new DataTransfer(); t.items.add(new File([text], "mocap.csv")); return t; }""", text
    )
    page.dispatch_event("#validation-file-zone", "drop", {"dataTransfer": transfer})
    page.wait_for_selector("#validation-preview table")
    header = page.locator("#validation-preview thead").inner_text()
    assert "point p1 x" in header and "point p4 z" in header and "σ of the record" in header
    page.select_option("#validation-length-unit", "m")
    assert page.locator("#validation-length-unit").input_value() == "m"
