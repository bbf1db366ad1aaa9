"""Program compensation in /ui by clicks and file uploads: a KUKA backup (weld.src, weld.dat, $config.dat in
Windows-1252) compensated for a UR5-like robot whose version 2 is a perturbed truth. Every displayed correction
is checked against the API's JSON answer, the downloaded files (bytes in their own encoding) are re-read and run by
the nominal controller on the truth (an independent forward kinematics: they land on their targets), and every
byte but the targets' digits is the upload's. Members the API may gain (a "left alone" list, a frame's name, a
target's warnings) and its job form (a work-too-large answer, then 202 and a job) are shown when present; a
refused program says where."""

from __future__ import annotations

import json
import uuid
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import urlparse

import httpx
import numpy as np
import pytest

from harness.programs import FIXTURE, HOME_DEG, Cell, executed, joints, ur5_cell
from models.description.examples import ur5_like_document
from programs import read_program
from tests.cli.test_compensate import N_TARGETS, backup, skeleton
from tests.ui.conftest import screenshot, watched_page
from tests.ui.pages import ready

pytestmark = pytest.mark.slow  # a browser against the live server of tests/ui


NAMES: dict[str, str] = {}
"""The programs robots' names by id (`robot`)."""


@pytest.fixture(scope="module")
def cell() -> Cell:
    return ur5_cell()


@pytest.fixture(scope="module")
def robot(server: str, cell: Cell) -> str:
    """A UR5-like robot with the truth imported as its version 2 (set up through the API: the page under test is
    the program's)."""
    with httpx.Client(base_url=server, timeout=60) as api:
        # A name of its own each time: a worker may run this module twice (pytest-xdist's work stealing) against
        # its one session server, where names are unique.
        name = f"ur5-programs-{uuid.uuid4().hex[:8]}"
        created = api.post("/v1/robots", json={"name": name, "structure": ur5_like_document()})
        assert created.status_code == 201, created.text
        robot_id = str(created.json()["id"])
        NAMES[robot_id] = name
        export = api.get(f"/v1/robots/{robot_id}/parameters").json()
        boundary = dict(zip(cell.desc.parameters.names, cell.desc.parameters.as_boundary(cell.truth), strict=True))
        for row in export["parameters"]:
            row["value"] = float(boundary[row["name"]])
        assert api.post(f"/v1/robots/{robot_id}/parameter-versions", json=export).status_code == 201
    return robot_id


@pytest.fixture
def page(browser: Any, server: str) -> Iterator[Any]:
    yield from watched_page(browser, server, viewport={"width": 1400, "height": 900}, accept_downloads=True)


def _open(page: Any, server: str, robot: str) -> None:
    """From the header's Programs link, the robot's row."""
    page.goto(f"{server}/ui#/")
    ready(page, "^#/$")
    page.get_by_role("navigation", name="main").get_by_role("link", name="Programs").click()
    ready(page, "^#/programs$")
    page.locator("#program-robots tr", has_text=NAMES[robot]).get_by_role("link").click()
    ready(page, f"^#/robots/{robot}/programs$")


def _cells(page: Any, selector: str) -> list[list[str]]:
    rows: list[list[str]] = page.eval_on_selector_all(
        f"{selector} tbody tr", "rows => rows.map(r => [...r.cells].map(c => c.textContent.trim()))"
    )
    return rows


def test_a_krl_backup_is_compensated_by_clicks_and_downloaded(
    page: Any, server: str, robot: str, cell: Cell, tmp_path: Path
) -> None:
    q = joints(N_TARGETS, seed=31)
    files = backup(cell, q, tmp_path / "KRC")
    _open(page, server, robot)
    page.set_input_files("#program-files", [str(files[n]) for n in ("weld.dat", "$config.dat", "weld.src")])
    page.wait_for_selector("#program-files-table")
    listed = _cells(page, "#program-files-table")
    assert [row[1:4] for row in listed] == [[n, "krl", "windows-1252"] for n in ("weld.dat", "$config.dat", "weld.src")]
    assert page.get_by_label("weld.src is the program").is_checked()  # the .src, though dropped last
    assert "(current)" in page.locator("#program-version option:checked").inner_text()
    page.get_by_label("Seed joints", exact=False).fill(", ".join(str(v) for v in HOME_DEG))
    with page.expect_response(lambda r: "/programs/compensate" in r.url) as answered:
        page.get_by_role("button", name="Compensate").click()
    sent = answered.value.request.post_data_json
    assert (sent["format"], sent["version"], sent["seed"]) == ("krl", 2, list(HOME_DEG))
    assert sorted(sent["files"]) == ["$config.dat", "weld.dat"]
    assert sent["program"] == files["weld.src"].read_bytes().decode("cp1252")
    answer = answered.value.json()
    page.wait_for_selector("#program-targets")
    screenshot(page, "program-compensated")

    # Each displayed correction is the API's, at the printed decimals.
    targets = answer["targets"]
    rows = _cells(page, "#program-targets")
    assert len(rows) == len(targets) == N_TARGETS + 1
    for row, t in zip(rows, targets, strict=True):
        assert row[:6] == [t["file"] or "weld.src", str(t["line"]), t["name"], t["base_frame"], t["tool_frame"],
                           "corrected" if t["reached"] else "kept"]  # fmt: skip
        if t["reached"]:
            shift, turn = np.array(t["correction_mm"]), np.array(t["correction_deg"])
            assert row[6:10] == [f"{v:.3f}" for v in [*shift, np.linalg.norm(shift)]]
            assert row[10:14] == [f"{v:.4f}" for v in [*turn, np.linalg.norm(turn)]]
        else:
            assert row[6:14] == ["—"] * 8 and row[14].startswith(t["reason"])
        # Members the page has no column for (the branch, a warning) follow the reason as notes.
        for member in ("branch", "warning"):
            if t.get(member):
                assert f"{member.capitalize()}: {t[member]}" in row[14]
    kept = [t for t in targets if not t["reached"]]
    assert [t["name"] for t in kept] == ["XFAR"]
    largest = max(np.linalg.norm(t["correction_mm"]) for t in targets if t["reached"])
    assert (
        page.locator("#program-summary")
        .inner_text()
        .startswith(
            f"{N_TARGETS} of {N_TARGETS + 1} targets corrected for version 2, 1 kept as written; "
            f"the largest correction {largest:.3f} mm"
        )
    )
    page.get_by_label("Only the targets kept as written").check()
    assert page.locator("#program-targets tbody tr:visible").count() == 1
    # The lines that changed: one per corrected target, all in the .dat.
    changes = _cells(page, "#program-changes-table")
    assert [(r[0], r[1]) for r in changes] == [("weld.dat", str(t["line"])) for t in targets if t["reached"]]
    assert "Unchanged (no target in them): $config.dat." in page.locator("#program-downloads").inner_text()

    _downloads_land_on_their_targets(page, answer, files, cell, q, tmp_path / "downloaded")


def _downloads_land_on_their_targets(
    page: Any, answer: dict[str, Any], files: dict[str, Path], cell: Cell, q: np.ndarray, out: Path
) -> None:
    """The downloads: Windows-1252 bytes, every byte but the targets' digits the upload's; re-read and run by the
    nominal controller on the true robot, they land on the taught targets (the independent truth)."""
    out.mkdir()
    buttons = page.locator("#program-downloads button")
    assert buttons.all_inner_texts() == ["Download weld.src", "Download weld.dat"]
    for k in range(buttons.count()):
        with page.expect_download() as caught:
            buttons.nth(k).click()
        caught.value.save_as(out / caught.value.suggested_filename)
    text = {}
    for name in ("weld.src", "weld.dat"):
        data = (out / name).read_bytes()
        assert skeleton(data) == skeleton(files[name].read_bytes())
        text[name] = data.decode("cp1252")
        assert text[name] == (answer["program"] if name == "weld.src" else answer["files"][name])
    uploaded = {name: path.read_bytes().decode("cp1252") for name, path in files.items()}
    config = uploaded["$config.dat"]
    again = read_program("krl", text["weld.src"], {"weld.dat": text["weld.dat"], "$config.dat": config})
    original = read_program("krl", uploaded["weld.src"], {"weld.dat": uploaded["weld.dat"], "$config.dat": config})
    names = [f"XP{k}" for k in range(1, N_TARGETS + 1)]
    poses = {t.name: t.pose for t in again.targets}
    taught_poses = {t.name: t.pose for t in original.targets}
    wanted = (cell.base @ FIXTURE @ np.array([taught_poses[n] for n in names]))[:, :3, 3]
    landed = executed(cell, np.array([poses[n] for n in names]), q, base=FIXTURE, tool=cell.tool)
    uncompensated = executed(cell, np.array([taught_poses[n] for n in names]), q, base=FIXTURE, tool=cell.tool)
    assert np.linalg.norm(landed - wanted, axis=1).max() < 0.05
    assert np.linalg.norm(uncompensated - wanted, axis=1).mean() > 0.5


def test_members_the_api_may_gain_and_its_job_form_are_shown(
    page: Any, server: str, robot: str, cell: Cell, tmp_path: Path
) -> None:
    """The service's real answer, with members added as a newer API would send them, after a work-too-large
    refusal that allows a job and the job's 202: the page follows the job and shows what it does not know by name."""
    files = backup(cell, joints(2, seed=32), tmp_path)
    posts: list[str] = []
    job: dict[str, Any] = {}

    def compensate(route: Any) -> None:
        posts.append(route.request.url)
        if "async=true" not in route.request.url:
            problem = {"type": "https://iwr-calibration.example/problems/work-too-large", "status": 422,
                       "title": "Too much work", "detail": "over the 2 s budget", "use_async": True}  # fmt: skip
            route.fulfill(status=422, content_type="application/problem+json", body=json.dumps(problem))
            return
        real = route.fetch(url=route.request.url.split("?")[0]).json()
        real["targets"][0]["warnings"] = ["configuration not declared: the branch of the joints before it"]
        real["left_alone"] = [
            {"file": "weld.dat", "line": 30, "name": "nZähler", "reason": "data: no motion goes to it"}
        ]
        real["frame"] = "base_link <b>bold</b>"  # server text is text, never markup
        real["warnings"] = [*real.get("warnings", []), "a warning as a plain string"]
        job.update(id="job-p1", kind="program_compensation", status="succeeded", result=real,
                   progress={"stage": "done", "fraction": 1.0}, cancel_requested=False)  # fmt: skip
        accepted = {"job_id": "job-p1", "status_url": "/v1/jobs/job-p1", "id": "job-p1"}
        route.fulfill(status=202, content_type="application/json", body=json.dumps(accepted))

    page.route("**/programs/compensate*", compensate)
    page.route("**/v1/jobs/job-p1", lambda route: route.fulfill(status=200, content_type="application/json",
                                                                 body=json.dumps(job)))  # fmt: skip
    _open(page, server, robot)
    page.set_input_files("#program-files", [str(p) for p in files.values()])
    page.wait_for_selector("#program-files-table")
    page.get_by_role("button", name="Compensate").click()
    page.wait_for_selector("#program-targets")
    screenshot(page, "program-extras")
    assert [urlparse(u).query for u in posts] == ["", "async=true"]
    assert "sent again as a job" in page.locator("#program-as-job").inner_text()
    assert "succeeded" in page.locator("#job-status").inner_text()
    assert _cells(page, "#program-left-alone") == [["weld.dat", "30", "nZähler", "data: no motion goes to it"]]
    assert page.locator("#program-facts dd[data-key=frame]").inner_text() == "base_link <b>bold</b>"
    assert page.locator("#program-facts b").count() == 0
    assert "Warnings: configuration not declared" in _cells(page, "#program-targets")[0][14]
    assert "a warning as a plain string" in page.locator("#program-warnings").inner_text()


def test_a_refused_program_says_where(page: Any, server: str, robot: str, tmp_path: Path) -> None:
    program = tmp_path / "probe.src"
    program.write_bytes(b"DEF probe( )\r\n$TOOL = TOOL_DATA[3]\r\nLIN {X 500,Y 0,Z 600,A 0,B 90,C 0}\r\nEND\r\n")
    _open(page, server, robot)
    page.set_input_files("#program-files", str(program))
    page.wait_for_selector("#program-files-table")
    with page.expect_response(lambda r: "/programs/compensate" in r.url) as answered:
        page.get_by_role("button", name="Compensate").click()
    problem = answered.value.json()
    assert answered.value.status == 422
    page.wait_for_selector("#program-refused")
    assert problem["detail"] in page.locator("#program-refused").inner_text()
    assert page.locator("#program-refused-where").inner_text().startswith(f"At the program, line {problem['line']}")


def test_files_decode_and_encode_back_to_their_bytes_in_the_browser(page: Any, server: str) -> None:
    """The page's own codec (views/programs.js): the 256 bytes as Windows-1252, UTF-8 with and without its mark,
    UTF-16 of either order: decoded and encoded back, each is the same bytes."""
    page.goto(f"{server}/ui#/jobs")
    ready(page, "^#/jobs$")
    cases = {
        "cp1252": (list(range(256)), "windows-1252"),
        "utf8": (list("; Schweißnaht\r\n".encode()), "utf-8"),
        "utf8-bom": (list("; Schweißnaht\r\n".encode("utf-8-sig")), "utf-8"),
        "utf16le": (list("MODULE Maße\r\n".encode("utf-16-le")), "windows-1252"),  # no mark: not taken for UTF-16
        "utf16le-bom": (list(b"\xff\xfe" + "MODULE Maße\r\n".encode("utf-16-le")), "utf-16le"),
        "utf16be-bom": (list(b"\xfe\xff" + "MODULE Maße\r\n".encode("utf-16-be")), "utf-16be"),
    }
    found = page.evaluate(
        """async (cases) => {
          const { decodeFile, encodeText } = await import('/ui/static/views/programs.js');
          const out = {};
          for (const [key, [bytes]] of Object.entries(cases)) {
            const file = decodeFile('a.src', Uint8Array.from(bytes).buffer);
            out[key] = [file.encoding, [...encodeText(file, file.text)]];
          }
          return out;
        }""",
        cases,
    )
    for key, (data, encoding) in cases.items():
        assert found[key] == [encoding, data], key
