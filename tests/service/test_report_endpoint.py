"""GET /v1/calibrations/{id}/report: built from the stored calibration, its campaign, its correlation matrix and the
validations of the version it produced; the page's numbers are the API's."""

from __future__ import annotations

import re

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models import iwr, sample_workspace
from models.simulation import perturbed_robot
from tests.service.helpers import records
from tests.service.test_reports import _Values

DESC = iwr()


@pytest.mark.slow  # HTML and PDF through the API: ~5 s here
def test_report_html_and_pdf(client: TestClient, robot_id: str) -> None:
    sim = perturbed_robot(DESC, seed=101)
    recs = records(DESC, sim, sample_workspace(DESC, 40, seed=102), seed=103)
    calibration = client.post(f"/v1/robots/{robot_id}/calibrations", json={"measurements": recs}).json()
    # The stored correlation matrix: symmetric, unit diagonal, on the estimated parameters.
    correlation = calibration["correlation"]
    matrix = np.array(correlation["matrix"], dtype=float)
    assert correlation["names"] == calibration["identifiable"] and matrix.shape == (54, 54)
    np.testing.assert_allclose(np.diag(matrix), 1.0, atol=1e-12)
    np.testing.assert_allclose(matrix, matrix.T, atol=1e-12)
    pairs = {(p["a"], p["b"]): p["correlation"] for p in calibration["correlated_pairs"]}
    index = {n: i for i, n in enumerate(correlation["names"])}
    for (a, b), r in pairs.items():
        assert matrix[index[a], index[b]] == np.float64(r) or abs(matrix[index[a], index[b]] - r) < 1e-9

    assert calibration["noise"] == {"position_mm": 0.025, "orientation_deg": pytest.approx(0.01)}  # the defaults
    validation = client.post(
        f"/v1/robots/{robot_id}/validations",
        json={"measurements": records(DESC, sim, np.repeat(sample_workspace(DESC, 2, seed=104), 3, axis=0), seed=105)},
    ).json()

    url = f"/v1/calibrations/{calibration['id']}/report"
    page = client.get(url, headers={"Accept": "text/html"})
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    parsed = _Values()
    parsed.feed(page.text)
    assert float(parsed.values["residuals.after.rms_mm"]) == calibration["residuals"]["after"]["rms_mm"]
    assert float(parsed.values["residuals.before.max_mm"]) == calibration["residuals"]["before"]["max_mm"]
    assert float(parsed.values["variance_factor"]) == calibration["variance_factor"]
    assert int(parsed.values["parameter_version"]) == calibration["parameter_version"] == 2
    assert "fig-correlation" in parsed.figures and "fig-measured-poses" in parsed.figures
    assert validation["id"] in page.text and "ISO 9283 pose" in page.text
    assert not re.search(r'(src|href)="(https?:)?//', page.text)
    # The downloads the web page offers, for the version this calibration produced; each one answers.
    for fmt in ("json", "csv", "urdf", "dh", "ur-calibration"):
        href = f"/v1/robots/{robot_id}/parameters?version=2&amp;format={fmt}"
        assert href in page.text, fmt
    assert client.get(f"/v1/robots/{robot_id}/parameters?version=2&format=csv").status_code == 200

    pdf = client.get(url + "?format=pdf", headers={"Accept": "text/html"})  # the query wins
    assert pdf.status_code == 200 and pdf.content.startswith(b"%PDF")
    assert client.get(url, headers={"Accept": "application/json"}).status_code == 406
    assert client.get("/v1/calibrations/nope/report").status_code == 404
