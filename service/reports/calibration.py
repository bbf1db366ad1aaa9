"""A calibration report an engineer can hand on: one self-contained HTML page, or a PDF with the same content.

The report is built from what the API serves (the stored calibration document, its campaign, optionally the
validations of the versions it produced), so every number in it is one a client can read back; the test compares
them. HTML: inline SVG figures and CSS, nothing fetched (plant networks are offline). PDF: matplotlib's PdfPages,
a title page with the summary, then the same figures and the parameter table.
"""

from __future__ import annotations

import html
import io
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from models.identification.statistics import NOISE_CONSISTENCY_LEVEL, variance_factor_interval
from service.reports import figures
from service.reports.blocks import cell, figures_html, page, summary_rows, summary_table, table, text_lines, text_page
from service.reports.figures import Array

PARAMETER_ROWS_PER_PDF_PAGE = 38
OUTLIER_HEADER = ["pose", "position error (mm)", "orientation error (°)", "statistic", "threshold", "excluded"]
NO_OUTLIERS = "No pose failed the outlier test."
ISO_HEADER = ["ISO 9283 pose", "cycles", "AP (mm)", "RP (mm)"]
FLEET_HEADER = ["parameter", "unit", "this unit (offset)", "fleet mean offset", "fleet spread", "z", "limit", "flagged"]
REFERENCE_HEADER = [
    "kind",
    "name",
    "records",
    "position (mm) / normal",
    "length or plane offset (mm)",
    "largest std error",
    "RMS residual (mm)",
]
SUMMARY = (
    ("status", "Status"),
    ("reason", "Reason"),
    ("applied", "Applied"),
    ("start_version", "Started from version"),
    ("parameter_version", "Produced version"),
    ("measurement", "Measurement"),
    ("measurements", "Poses"),
    ("frame", "Frame"),
    ("residuals.before.rms_mm", "RMS error before (mm)"),
    ("residuals.after.rms_mm", "RMS error after (mm)"),
    ("residuals.before.max_mm", "Max error before (mm)"),
    ("residuals.after.max_mm", "Max error after (mm)"),
    ("residuals.before.rms_deg", "RMS orientation error before (°)"),
    ("residuals.after.rms_deg", "RMS orientation error after (°)"),
    ("predicted_accuracy.rms_position_mm", "Predicted TCP accuracy, RMS (mm)"),
    ("predicted_accuracy.max_position_mm", "Predicted TCP accuracy, max (mm)"),
    ("variance_factor", "Variance factor"),
    ("noise_consistent", "Noise as stated"),
    ("rank", "Identifiable parameters"),
    ("condition_number", "Condition number"),
    ("solver.status", "Solver"),
    ("solver.iterations", "Solver iterations"),
    # a drift-aware calibration's drift, and the conditions the produced version is calibrated for
    ("drift.magnitude_mm", "Instrument drift over the campaign, removed (mm)"),
    ("drift.reference_scatter.before_mm", "Reference pose scatter as measured (mm)"),
    ("drift.reference_scatter.after_mm", "Reference pose scatter, drift removed (mm)"),
    ("conditions.temperature_c.min", "Calibrated from temperature (°C)"),
    ("conditions.temperature_c.max", "Calibrated up to temperature (°C)"),
    ("conditions.payload_kg.min", "Calibrated from payload (kg)"),
    ("conditions.payload_kg.max", "Calibrated up to payload (kg)"),
    ("conditions.duration_s", "Campaign duration (s)"),
)
"""The summary table's rows: each (dotted key of the calibration document, label); one without a value is left
out."""


@dataclass(frozen=True)
class CalibrationReport:
    """What a report shows; `calibration` is the calibration document of the API (api.md keys)."""

    calibration: Mapping[str, Any]
    robot_name: str
    measured_positions: Array | None = None
    """(N, 3) the campaign's measured TCP positions, mm."""
    correlation: tuple[Sequence[str], Array] | None = None
    """Names and correlation matrix of the estimated parameters."""
    noise_position_mm: float | None = None
    validations: Sequence[Mapping[str, Any]] = field(default=())
    """Validation documents of this robot (api.md, validations) to show after the calibration."""
    history: Sequence[Mapping[str, Any]] = field(default=())
    """The robot's history events (`GET /v1/robots/{id}/history`, as JSON): its accuracy over time."""

    # ------------------------------------------------------------------ numbers, as the API states them
    @property
    def before(self) -> Mapping[str, Any]:
        return dict(self.calibration["residuals"]["before"])

    @property
    def after(self) -> Mapping[str, Any]:
        return dict(self.calibration["residuals"]["after"])

    @property
    def excluded(self) -> list[int]:
        return [int(o["pose"]) for o in self.calibration.get("outliers", []) if o.get("excluded")]

    @property
    def variance_interval(self) -> tuple[float, float] | None:
        stated = self.calibration.get("variance_factor_interval")
        if stated is not None:
            return float(stated[0]), float(stated[1])
        dof = int(self.calibration.get("degrees_of_freedom") or 0)
        if dof <= 0:
            return None
        return variance_factor_interval(dof)

    def summary(self) -> list[tuple[str, str, Any]]:
        """(key, label, value) rows of the summary table; keys are the API's, dotted."""
        return summary_rows(self.calibration, SUMMARY)

    def parameter_rows(self) -> list[dict[str, Any]]:
        confounding = self.calibration.get("confounding") or {}
        rows = []
        for p in self.calibration["parameters"]:
            start = p.get("start", p["nominal"])
            partners = ", ".join(f"{q['with']} ({q['coefficient']:+.3g})" for q in confounding.get(p["name"], []))
            rows.append(
                {
                    "name": p["name"],
                    "unit": p["unit"],
                    "value": p["value"],
                    "nominal": p["nominal"],
                    "change": p["value"] - start,
                    "std_error": p["std_error"],
                    "identifiable": p["identifiable"],
                    "confounded_with": partners,
                }
            )
        return rows

    def outlier_rows(self) -> list[list[Any]]:
        """The records that failed the outlier test, worst first (`OUTLIER_HEADER`)."""
        outliers = self.calibration.get("outliers") or []
        return [
            [o["pose"], o["position_mm"], o.get("orientation_deg"), o["statistic"], o["threshold"], o["excluded"]]
            for o in sorted(outliers, key=lambda o: -float(o["statistic"]))
        ]

    def reference_rows(self) -> list[list[Any]]:
        """One row per identified anchor, point or plane: what it is, where, its records' RMS residual."""
        rows = []
        for ref in self.calibration.get("references") or []:
            where = ref.get("position_mm") or ref.get("normal")
            # an anchor's length offset or a plane's offset: each reference states at most one
            extra = ref.get("length_offset_mm") if ref.get("length_offset_mm") is not None else ref.get("offset_mm")
            std = max((u["std_error"] or 0.0) for u in ref["unknowns"]) if ref["unknowns"] else None
            located = ", ".join(f"{v:.4f}" for v in where) if where else ""
            rows.append([ref["kind"], ref["name"], ref["records"], located, extra, std, ref["rms_residual_mm"]])
        return rows

    def fleet_rows(self) -> list[list[Any]]:
        """This unit against its fleet's population, farthest first (`FLEET_HEADER`); empty without one."""
        fleet = self.calibration.get("fleet") or {}
        rows = sorted(fleet.get("parameters") or [], key=lambda p: -abs(float(p["z"])))
        return [
            [p["name"], p["unit"], p["offset"], p["mean_offset"], p["spread"], p["z"], p["limit"], p["flagged"]]
            for p in rows
        ]

    def fleet_line(self) -> str:
        fleet = self.calibration.get("fleet") or {}
        if not fleet:
            return ""
        verdict = "an outlier: not like the others" if fleet.get("outlier") else "like the others"
        prior = ", calibrated with the fleet's prior" if fleet.get("prior_used") else ""
        return f"fleet {fleet.get('fleet')}: against {fleet.get('units')} other calibrated units, {verdict}{prior}"

    # ------------------------------------------------------------------ figures
    def figures(self) -> list[tuple[str, Figure]]:
        before = np.asarray(self.before.get("per_pose_mm") or [], dtype=float)
        after = np.asarray(self.after.get("per_pose_mm") or [], dtype=float)
        out: list[tuple[str, Figure]] = []
        if before.size and after.size == before.size:
            out.append(("residual-bars", figures.residual_bars(before, after, self.excluded)))
            out.append(("residual-histograms", figures.residual_histograms(before, after, self.noise_position_mm)))
        if self.measured_positions is not None and after.size == len(self.measured_positions):
            out.append(("measured-poses", figures.measured_poses_3d(self.measured_positions, after)))
        interval = self.variance_interval
        vf = self.calibration.get("variance_factor")
        if interval is not None and vf is not None and math.isfinite(vf):
            dof = int(self.calibration["degrees_of_freedom"])
            out.append(("variance-factor", figures.variance_factor_test(vf, interval, dof, NOISE_CONSISTENCY_LEVEL)))
        if len(self.history) >= 2:
            at = [datetime.fromisoformat(str(e["at"])) for e in self.history]
            ids = [e["id"] for e in self.history]
            marked = ids.index(self.calibration.get("id")) if self.calibration.get("id") in ids else -1
            measured = [e.get("rms_mm") for e in self.history]
            predicted = [e.get("predicted_mm") for e in self.history]
            out.append(("accuracy-history", figures.accuracy_history(at, measured, predicted, marked)))
        estimated = [r for r in self.parameter_rows() if r["identifiable"] and r["std_error"]]
        if estimated:
            out.append(
                (
                    "parameter-changes",
                    figures.parameter_changes(
                        [r["name"] for r in estimated],
                        np.array([r["change"] for r in estimated], dtype=float),
                        np.array([r["std_error"] for r in estimated], dtype=float),
                    ),
                )
            )
        if self.correlation is not None:
            names, matrix = self.correlation
            out.append(("correlation", figures.correlation_heatmap(names, np.asarray(matrix, dtype=float))))
        return out


def validation_sections(
    validations: Sequence[Mapping[str, Any]],
) -> list[tuple[Mapping[str, Any], str, list[list[Any]]]]:
    """Per validation result of the produced version: (the result, its one-line summary, its ISO 9283 rows)."""
    sections = []
    for v in validations:
        for r in v.get("results", []):
            pos = r["position_mm"]
            line = (
                f"Validation {v.get('id')}, version {r['version']}: RMS {cell(pos['rms'])} mm, max "
                f"{cell(pos['max'])} mm over {len(r.get('per_pose', []))} poses."
            )
            iso = (r.get("iso9283") or {}).get("poses") or []
            rows = [[k + 1, p["cycles"], p["AP_mm"], p["RP_mm"]] for k, p in enumerate(iso)]
            sections.append((r, line, rows))
    return sections


def _validation_html(validations: Sequence[Mapping[str, Any]]) -> str:
    parts = ["<h2>Validation</h2>"]
    for v in validations:
        for r, _, rows in validation_sections([v]):
            pos = r["position_mm"]
            parts.append(
                f"<p>Validation <code>{html.escape(str(v.get('id')))}</code>, version {r['version']}: "
                f'RMS <span data-key="validation.rms">{cell(pos["rms"])}</span> mm, max {cell(pos["max"])} mm'
                f" over {len(r.get('per_pose', []))} poses.</p>"
            )
            if rows:
                parts.append(table(ISO_HEADER, rows))
    return "".join(parts)


EXPORT_FORMATS = (
    ("json", "parameters (JSON)"),
    ("csv", "parameters (CSV)"),
    ("urdf", "URDF"),
    ("dh", "DH table"),
    ("ur-calibration", "UR calibration YAML"),
)
"""What the web page offers for a version, the report too (a hexapod's URDF or DH table is refused, saying why)."""


def _downloads_html(c: Mapping[str, Any]) -> str:
    """Links to the produced version's exports and to the campaign, relative to the service (no host)."""
    version, robot = c.get("parameter_version"), c.get("robot_id")
    items = []
    if version is not None and robot is not None:
        base = f"/v1/robots/{html.escape(str(robot))}/parameters?version={int(version)}&amp;format="
        items += [
            f'<li><a href="{base}{fmt}">{label}</a> of version {int(version)}</li>' for fmt, label in EXPORT_FORMATS
        ]
    if c.get("campaign_id"):
        items.append(
            f'<li><a href="/v1/campaigns/{html.escape(str(c["campaign_id"]))}?format=csv">the campaign (CSV)</a></li>'
        )
    return f'<h2>Downloads</h2><ul class="downloads">{"".join(items)}</ul>' if items else ""


def render_html(report: CalibrationReport) -> str:
    c = report.calibration
    title = f"Calibration of {report.robot_name}"
    status_class = "ok" if c.get("status") == "succeeded" else "failed"
    outlier_html = table(OUTLIER_HEADER, report.outlier_rows()) if report.outlier_rows() else f"<p>{NO_OUTLIERS}</p>"
    params = table(
        ["parameter", "unit", "value", "nominal", "change", "std error", "identifiable", "confounded with"],
        [
            [
                r["name"],
                r["unit"],
                r["value"],
                r["nominal"],
                r["change"],
                r["std_error"],
                r["identifiable"],
                r["confounded_with"],
            ]
            for r in report.parameter_rows()
        ],
        css="parameters",
    )
    notes = "".join(f'<p class="note">{html.escape(str(n))}</p>' for n in c.get("notes") or [])
    references = (
        "<h2>References</h2>" + table(REFERENCE_HEADER, report.reference_rows(), css="references")
        if report.reference_rows()
        else ""
    )
    validation = _validation_html(report.validations) if report.validations else ""
    fleet = (
        f"<h2>Fleet</h2><p>{html.escape(report.fleet_line())}</p>" + table(FLEET_HEADER, report.fleet_rows())
        if report.fleet_line()
        else ""
    )
    return page(
        title,
        f'<p>Calibration <code data-key="id">{html.escape(str(c.get("id")))}</code>, '
        f"{html.escape(str(c.get('created_at')))}: "
        f'<b class="{status_class}">{html.escape(str(c.get("status")))}</b></p>'
        f"{notes}<h2>Summary</h2>{summary_table(report.summary())}"
        f"<h2>Figures</h2>{figures_html(report.figures())}"
        f"<h2>Outliers</h2>{outlier_html}{references}{validation}{fleet}"
        f"<h2>Parameters</h2>{params}{_downloads_html(c)}",
    )


def render_pdf(report: CalibrationReport) -> bytes:
    c = report.calibration
    summary = [f"{label:<36} {cell(value)}" for _, label, value in report.summary()]
    summary += ["", *(str(n) for n in c.get("notes") or [])]
    out = io.BytesIO()
    with PdfPages(out, metadata={"Title": f"Calibration of {report.robot_name}", "Subject": str(c.get("id"))}) as pdf:
        pdf.savefig(text_page(f"Calibration of {report.robot_name} — {c.get('id')}", summary))
        for _, fig in report.figures():
            pdf.savefig(fig, bbox_inches="tight")
        rows = [
            f"{r['name']:<14} {r['unit']:<4} {cell(r['value']):>14} {cell(r['nominal']):>12} "
            f"{cell(r['change']):>12} {cell(r['std_error']):>12} {'yes' if r['identifiable'] else 'no':>4}"
            for r in report.parameter_rows()
        ]
        header = (
            f"{'parameter':<14} {'unit':<4} {'value':>14} {'nominal':>12} {'change':>12} {'std error':>12} {'id.':>4}"
        )
        for start in range(0, len(rows), PARAMETER_ROWS_PER_PDF_PAGE):
            page = [header, *rows[start : start + PARAMETER_ROWS_PER_PDF_PAGE]]
            pdf.savefig(text_page("Parameters", page))
        # Every section of the HTML report, as text pages: outliers, references, validations with ISO 9283.
        outliers = report.outlier_rows()
        pdf.savefig(text_page("Outliers", text_lines(OUTLIER_HEADER, outliers) if outliers else [NO_OUTLIERS]))
        if report.reference_rows():
            lines = text_lines(REFERENCE_HEADER, report.reference_rows())
            pdf.savefig(text_page("References", [*lines, "", str(c.get("frame") or "")]))
        if report.validations:
            lines = []
            for _, line, iso in validation_sections(report.validations):
                lines += [line, *(text_lines(ISO_HEADER, iso) if iso else []), ""]
            pdf.savefig(text_page("Validation", lines))
        if report.fleet_line():
            pdf.savefig(text_page("Fleet", [report.fleet_line(), "", *text_lines(FLEET_HEADER, report.fleet_rows())]))
    return out.getvalue()
