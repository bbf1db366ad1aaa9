"""Calibration reports (HTML and PDF) with real figures."""

from service.reports.calibration import CalibrationReport, render_html, render_pdf

__all__ = ["CalibrationReport", "render_html", "render_pdf"]
