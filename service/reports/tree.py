"""A tree calibration's report (issue 47): the single-chain report's form (`service.reports.calibration`: one
self-contained HTML page with inline SVG, or a PDF of the same figures and tables) for a cell of several chains.

What it shows is what a cell's process needs: each tool's fit and held-out error, and the RELATIVE accuracy of
each pair of tools (the torch in the part's frame, one hand in the other's) over joint vectors of the region the
records covered: the predicted 1-σ error after the calibration at each of them, and how far the calibration moved
that relative position (the error the tree had before it, as the fit sees it). The tables' numbers are the
calibration document's (`TreeCalibrationPublic`, as the API serves it); the test compares them.
"""

from __future__ import annotations

import html
import io
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from service.reports.blocks import (
    cell,
    figures_html,
    keyed_table,
    page,
    summary_rows,
    summary_table,
    table,
    text_lines,
    text_page,
)
from service.reports.figures import AFTER, BEFORE, WIDTH_IN, Array

ERROR_HEADER = ["records of", "records", "RMS (mm)", "max (mm)", "RMS before (mm)"]
ACCURACY_HEADER = ["tool (in frame)", "RMS position (mm)", "max position (mm)", "RMS orientation (°)"]
REGION_HEADER = ["tool in frame", "poses", "predicted RMS (mm)", "predicted max (mm)", "moved by the fit, RMS (mm)"]
BRANCH_HEADER = ["branch", "parent", "joints", "stages", "tool"]
HELD_OUT = "#9bbb59"
SUMMARY = (
    ("applied", "Applied"),
    ("start_revision", "Started from revision"),
    ("revision", "Produced revision"),
    ("records", "Records fitted"),
    ("held_out_records", "Records held out"),
    ("variance_factor", "Variance factor"),
    ("noise_consistent", "Noise as stated"),
)
"""The summary table's rows read off the calibration document (its parameters' counts follow)."""


@dataclass(frozen=True)
class RelativeProfile:
    """One pair's relative position accuracy over the report's joint vectors (mm, one value per vector)."""

    label: str
    predicted_mm: Array
    """The predicted 1-σ position error of tool in frame's frame after the calibration."""
    moved_mm: Array | None
    """|p_after − p_before| of tool in frame's frame; None when the calibration did not store its start."""


@dataclass(frozen=True)
class TreeReport:
    calibration: Mapping[str, Any]
    """The calibration document of the API (`TreeCalibrationPublic` as JSON)."""
    tree: Mapping[str, Any]
    """The tree document of the API (`RobotTreePublic` as JSON): its name and branches."""
    profiles: Sequence[RelativeProfile]
    region: str
    """How the joint vectors of the profiles were drawn, in words."""

    def summary(self) -> list[tuple[str, str, Any]]:
        c = self.calibration
        return [
            *summary_rows(c, SUMMARY),
            ("estimated", "Parameters estimated", len(c.get("estimated") or [])),
            ("unidentifiable", "Parameters held", len(c.get("unidentifiable") or [])),
        ]

    def error_rows(self, key: str) -> list[list[Any]]:
        return [
            [e["label"], e["records"], e["rms_mm"], e["max_mm"], e.get("before_rms_mm")] for e in self.calibration[key]
        ]

    def accuracy_rows(self) -> list[list[Any]]:
        return [
            [a["label"], a["rms_position_mm"], a["max_position_mm"], a["rms_orientation_deg"]]
            for a in self.calibration["accuracy"]
        ]

    def region_rows(self) -> list[list[Any]]:
        return [
            [
                p.label,
                int(p.predicted_mm.size),
                rms(p.predicted_mm),
                float(p.predicted_mm.max()),
                None if p.moved_mm is None else rms(p.moved_mm),
            ]
            for p in self.profiles
        ]

    def branch_rows(self) -> list[list[Any]]:
        return [
            [
                b["name"],
                b.get("parent") or "(base)",
                ", ".join(b["joint_names"]),
                ", ".join(str(s.get("kind")) for s in b["stages"]) or "—",
                "yes" if b.get("tool") else "no",
            ]
            for b in self.tree["branches"]
        ]

    def figures(self) -> list[tuple[str, Figure]]:
        out = [("tool-errors", tool_errors(self.calibration["fit"], self.calibration["held_out"]))]
        if self.profiles:
            out.append(("relative-accuracy", relative_accuracy(self.profiles)))
        return out


def rms(values: Array) -> float:
    return float(np.sqrt(np.mean(np.asarray(values, dtype=float) ** 2)))


def tool_errors(fit: Sequence[Mapping[str, Any]], held_out: Sequence[Mapping[str, Any]]) -> Figure:
    """Per record group: the RMS error after the fit on its records, and on the held-out ones before and after."""
    labels = list(dict.fromkeys([e["label"] for e in fit] + [e["label"] for e in held_out]))
    fitted = {e["label"]: e["rms_mm"] for e in fit}
    held = {e["label"]: e for e in held_out}
    bars = [
        ("held out, before", BEFORE, [held[k].get("before_rms_mm") if k in held else None for k in labels]),
        ("fit", AFTER, [fitted.get(k) for k in labels]),
        ("held out, after", HELD_OUT, [held[k]["rms_mm"] if k in held else None for k in labels]),
    ]
    fig = Figure(figsize=(WIDTH_IN, 3.0))
    ax = fig.add_subplot()
    x = np.arange(len(labels))
    for k, (name, color, values) in enumerate(bars):
        y = np.array([np.nan if v is None else v for v in values], dtype=float)
        ax.bar(x + (k - 1) * 0.27, y, width=0.27, color=color, label=name)
    if np.any(np.array([v for _, _, vs in bars for v in vs if v is not None]) > 0):
        ax.set_yscale("log")
    ax.set_xticks(x, labels=labels)
    ax.set_ylabel("RMS position error (mm)")
    ax.set_title("Each tool's error: on the fitted records, and on the held-out ones before and after")
    ax.legend(loc="upper right", fontsize="small")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def relative_accuracy(profiles: Sequence[RelativeProfile]) -> Figure:
    """Per pair of tools, over the region's joint vectors sorted by it: the predicted 1-σ relative position error
    after the calibration (solid), and how far the calibration moved the relative position (dashed: the error
    before it). The x axis is the fraction of the region's poses at or below the value."""
    fig = Figure(figsize=(WIDTH_IN, 3.4))
    ax = fig.add_subplot()
    colors = [f"C{k}" for k in range(len(profiles))]
    for p, color in zip(profiles, colors, strict=True):
        ax.plot(*sorted_profile(p.predicted_mm), color=color, label=f"{p.label}: predicted after (1 σ)")
        if p.moved_mm is not None:
            ax.plot(*sorted_profile(p.moved_mm), color=color, linestyle="--", label=f"{p.label}: moved (≈ before)")
    ax.set_yscale("log")
    ax.set_xlabel("fraction of the region's poses")
    ax.set_ylabel("relative position error (mm)")
    ax.set_title("Tool in the other tool's frame, over the measured region")
    ax.legend(loc="best", fontsize="small")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def sorted_profile(values: Array) -> tuple[Array, Array]:
    """(x, y) of a profile as drawn: the fraction of the poses at or below each value, the values sorted."""
    y = np.sort(np.asarray(values, dtype=float))
    return np.arange(1, y.size + 1) / y.size, y


def render_html(report: TreeReport) -> str:
    c, t = report.calibration, report.tree
    params = table(
        ["parameter", "group", "unit", "value", "nominal", "std error"],
        [[p["name"], p["group"], p["unit"], p["value"], p["nominal"], p["std_error"]] for p in c["parameters"]],
        css="parameters",
    )
    return page(
        f"Calibration of the cell {t['name']}",
        f'<p>Calibration <code data-key="id">{html.escape(str(c.get("id")))}</code> of tree '
        f"<code>{html.escape(str(t.get('id')))}</code>, {html.escape(str(c.get('created_at')))}</p>"
        f"<h2>Summary</h2>{summary_table(report.summary())}"
        f"<h2>Branches</h2>{table(BRANCH_HEADER, report.branch_rows(), css='branches')}"
        f"<h2>Figures</h2>{figures_html(report.figures())}"
        f"<h2>Fit</h2>{keyed_table(ERROR_HEADER, report.error_rows('fit'), 'fit')}"
        f"<h2>Held out</h2>{keyed_table(ERROR_HEADER, report.error_rows('held_out'), 'held_out')}"
        "<h2>Predicted accuracy</h2><p>Each tool in the instrument's frame, then each tool in another's frame (the "
        "relative accuracy), over random joint vectors of the whole tree, as the calibration states it.</p>"
        f"{keyed_table(ACCURACY_HEADER, report.accuracy_rows(), 'accuracy')}"
        f"<h2>Relative accuracy over the measured region</h2><p>{html.escape(report.region)}</p>"
        f"{keyed_table(REGION_HEADER, report.region_rows(), 'region')}"
        f"<h2>Parameters</h2>{params}",
    )


def render_pdf(report: TreeReport) -> bytes:
    c, t = report.calibration, report.tree
    title = f"Calibration of the cell {t['name']}"
    summary = [f"{label:<28} {html.unescape(cell(value))}" for _, label, value in report.summary()]
    out = io.BytesIO()
    with PdfPages(out, metadata={"Title": title, "Subject": str(c.get("id"))}) as pdf:
        pdf.savefig(
            text_page(f"{title} — {c.get('id')}", [*summary, "", *text_lines(BRANCH_HEADER, report.branch_rows())])
        )
        for _, fig in report.figures():
            pdf.savefig(fig, bbox_inches="tight")
        lines = [
            "Fit",
            *text_lines(ERROR_HEADER, report.error_rows("fit")),
            "",
            "Held out",
            *text_lines(ERROR_HEADER, report.error_rows("held_out")),
            "",
            "Predicted accuracy (whole tree)",
            *text_lines(ACCURACY_HEADER, report.accuracy_rows()),
            "",
            report.region,
            *text_lines(REGION_HEADER, report.region_rows()),
        ]
        pdf.savefig(text_page("Accuracy", lines))
    return out.getvalue()
