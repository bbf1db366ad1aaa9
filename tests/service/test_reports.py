"""Calibration reports: the numbers on the page are the API's, the figures are real plots, the PDF has them too."""

from __future__ import annotations

import re
from html.parser import HTMLParser

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from service.reports import CalibrationReport, render_html, render_pdf
from tests.service.helpers import records

DESC = iwr()


class _Values(HTMLParser):
    """data-key → data-value of the summary cells, and the ids of the figures."""

    def __init__(self) -> None:
        super().__init__()
        self.values: dict[str, str] = {}
        self.figures: list[str] = []
        self.svgs = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if "data-key" in a and "data-value" in a:
            self.values[str(a["data-key"])] = str(a["data-value"])
        if tag == "figure":
            self.figures.append(str(a.get("id")))
        if tag == "svg":
            self.svgs += 1


def _calibration(client: TestClient, robot_id: str) -> tuple[dict[str, object], np.ndarray]:
    sim = perturbed_robot(DESC, seed=41)
    recs = records(DESC, sim, sample_workspace(DESC, 40, seed=42), seed=43)
    recs[7]["position"] = [v + 2.0 for v in recs[7]["position"]]  # type: ignore[attr-defined]
    body = client.post(
        f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs, "options": {"robust": "soft_l1"}}
    ).json()
    assert body["status"] == "succeeded"
    return body, np.array([r["position"] for r in recs], dtype=float)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_html_report_shows_the_api_numbers_and_real_figures(client: TestClient, robot_id: str) -> None:
    body, positions = _calibration(client, robot_id)
    names = list(body["identifiable"])  # type: ignore[call-overload]
    report = CalibrationReport(body, "cell-3", positions, (names, np.eye(len(names))), noise_position_mm=0.025)
    page = render_html(report)
    parsed = _Values()
    parsed.feed(page)
    after = body["residuals"]["after"]  # type: ignore[index]
    assert float(parsed.values["residuals.after.rms_mm"]) == after["rms_mm"]
    assert float(parsed.values["variance_factor"]) == body["variance_factor"]
    assert int(parsed.values["rank"]) == 54
    expected = ["residual-bars", "residual-histograms", "measured-poses", "variance-factor", "parameter-changes"]
    assert parsed.figures == [f"fig-{n}" for n in [*expected, "correlation"]]
    assert parsed.svgs >= len(parsed.figures)
    # Real plots: each figure holds drawn paths (bars, points), not just text.
    for figure in re.findall(r'<figure id="fig-[^"]+">(.*?)</figure>', page, flags=re.S):
        assert figure.count("<path") > 10
    # Self-contained: nothing the browser would fetch (offline plant networks).
    assert not re.search(r'(src|href)="(https?:)?//|<link |url\((https?:)?//|@import', page)
    # The blunder is listed as an excluded outlier and drawn in grey.
    assert '<td class="num">7</td>' in page


@pytest.mark.slow  # a PDF of every figure: ~7 s here
def _validation(calibration: dict[str, object]) -> dict[str, object]:
    """A validation document of the calibration's version with one ISO 9283 pose (the report's input shape)."""
    per_pose = [{"position_mm": 0.01}, {"position_mm": 0.012}]
    iso = {"poses": [{"joints": [0.0] * 10, "cycles": 2, "AP_mm": 0.011, "RP_mm": 0.004}], "distances": []}
    result = {"version": 2, "position_mm": {"rms": 0.011, "max": 0.012}, "per_pose": per_pose, "iso9283": iso}
    return {"id": "v-1", "results": [result]}


@pytest.mark.slow  # three PDF renderings: about four seconds
def test_pdf_report_has_every_figure_and_the_parameter_table(client: TestClient, robot_id: str) -> None:
    body, positions = _calibration(client, robot_id)
    report = CalibrationReport(body, "cell-3", positions)
    pdf = render_pdf(report)
    assert pdf.startswith(b"%PDF")
    pages = len(re.findall(rb"/Type\s*/Page[^s]", pdf))
    parameter_pages = -(-len(body["parameters"]) // 38)  # type: ignore[arg-type]
    assert pages == 1 + len(report.figures()) + parameter_pages + 1  # + the outliers' page, as the HTML has
    with_validation = CalibrationReport(body, "cell-3", positions, validations=[_validation(body)])
    pages = len(re.findall(rb"/Type\s*/Page[^s]", render_pdf(with_validation)))
    assert pages == 1 + len(report.figures()) + parameter_pages + 2  # and the validation's, with its ISO 9283
