"""The report's figures, drawn with matplotlib's object API (no pyplot: no global state shared between threads).

Each function returns a `Figure`; `svg()` turns one into inline SVG for the HTML report, and the PDF report
saves the same figures page by page, so both formats show the same plots.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from datetime import datetime

import matplotlib

matplotlib.use("Agg")  # no display on a server; set before any canvas is created

import numpy as np
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure
from numpy.typing import NDArray

Array = NDArray[np.float64]

BEFORE, AFTER, EXCLUDED = "#c0504d", "#2e75b6", "#7f7f7f"
WIDTH_IN = 8.0


def svg(fig: Figure) -> str:
    """Inline SVG (no XML prolog), so the HTML report needs no file next to it."""
    out = io.StringIO()
    # No RDF metadata block: it only dates the file, and reports of the same calibration should be identical.
    fig.savefig(
        out,
        format="svg",
        bbox_inches="tight",
        metadata={"Date": None, "Creator": None, "Format": None, "Type": None},
    )
    text = out.getvalue()
    return text[text.index("<svg") :]


def residual_bars(before_mm: Array, after_mm: Array, excluded: Sequence[int], *, unit: str = "mm") -> Figure:
    """Per-pose TCP error before and after the calibration, on a log axis (they differ by 10–100×)."""
    fig = Figure(figsize=(WIDTH_IN, 3.2))
    ax = fig.add_subplot()
    poses = np.arange(before_mm.size)
    ax.bar(poses - 0.2, before_mm, width=0.4, color=BEFORE, label="before")
    colors = [EXCLUDED if k in set(excluded) else AFTER for k in poses]
    ax.bar(poses + 0.2, after_mm, width=0.4, color=colors, label="after")
    positive = np.r_[before_mm, after_mm]
    positive = positive[positive > 0]
    if positive.size:
        ax.set_yscale("log")
    ax.set_xlabel("pose")
    ax.set_ylabel(f"error ({unit})")
    ax.set_title("Error per measured pose" + (" (grey: excluded as outlier)" if excluded else ""))
    ax.legend(loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    return fig


def residual_histograms(before_mm: Array, after_mm: Array, sigma_mm: float | None = None) -> Figure:
    """Distributions before and after; after a good calibration the second is about the instrument's noise."""
    fig = Figure(figsize=(WIDTH_IN, 3.0))
    for k, (values, color, title) in enumerate(((before_mm, BEFORE, "before"), (after_mm, AFTER, "after"))):
        ax = fig.add_subplot(1, 2, k + 1)
        ax.hist(values, bins=min(30, max(5, values.size // 3)), color=color, alpha=0.85)
        ax.set_title(f"{title}: RMS {np.sqrt(np.mean(values**2)):.4g} mm")
        ax.set_xlabel("position error (mm)")
        ax.set_ylabel("poses")
        if sigma_mm is not None and k == 1:
            # |e| of an isotropic Gaussian in 3-D has its mean at 2√2/√π σ ≈ 1.6 σ: where a clean fit centres.
            ax.axvline(1.596 * sigma_mm, color="k", linestyle="--", linewidth=1, label="expected mean (noise)")
            ax.legend(fontsize="small")
    fig.tight_layout()
    return fig


def measured_poses_3d(positions: Array, after_mm: Array) -> Figure:
    """Where the TCP was measured, coloured by the error left after calibration."""
    fig = Figure(figsize=(WIDTH_IN * 0.75, WIDTH_IN * 0.6))
    ax = fig.add_subplot(projection="3d")
    points = ax.scatter(positions[:, 0], positions[:, 1], positions[:, 2], c=after_mm, cmap="viridis", s=18)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title("Measured TCP positions (instrument frame)")
    fig.colorbar(points, ax=ax, shrink=0.7, label="error after (mm)")
    return fig


def correlation_heatmap(names: Sequence[str], matrix: Array) -> Figure:
    """Correlations of the estimated parameters: the blocks show what the campaign could not tell apart."""
    size = min(WIDTH_IN + 1, 3.0 + 0.11 * len(names))
    fig = Figure(figsize=(size + 1.2, size))
    ax = fig.add_subplot()
    image = ax.imshow(matrix, cmap="RdBu_r", norm=TwoSlopeNorm(vcenter=0.0, vmin=-1.0, vmax=1.0))
    ticks = np.arange(len(names))
    fontsize = 8 if len(names) <= 20 else 5
    ax.set_xticks(ticks, labels=list(names), rotation=90, fontsize=fontsize)
    ax.set_yticks(ticks, labels=list(names), fontsize=fontsize)
    ax.set_title("Correlation of the estimated parameters")
    fig.colorbar(image, ax=ax, shrink=0.8)
    fig.tight_layout()
    return fig


def variance_factor_test(value: float, interval: tuple[float, float], dof: int, level: float) -> Figure:
    """The a-posteriori variance factor against its χ² acceptance interval: is the stated noise the real one?"""
    fig = Figure(figsize=(WIDTH_IN, 1.6))
    ax = fig.add_subplot()
    lo, hi = interval
    span_hi = max(hi * 1.5, value * 1.2, 2.0)
    ax.axvspan(lo, hi, color="#d9ead3", label=f"accepted ({level:.0%}, {dof} dof)")
    ax.axvline(1.0, color="k", linewidth=0.8, linestyle=":")
    ax.plot([value], [0.5], marker="v", markersize=12, color=AFTER if lo <= value <= hi else BEFORE)
    ax.set_xlim(0, span_hi)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_xlabel("variance factor σ̂²/σ²")
    ax.legend(loc="upper right", fontsize="small")
    fig.tight_layout()
    return fig


def parameter_changes(names: Sequence[str], change: Array, std_error: Array) -> Figure:
    """Each estimated parameter's change from its start value, in units of its standard error."""
    fig = Figure(figsize=(WIDTH_IN, 3.0))
    ax = fig.add_subplot()
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(std_error > 0, np.abs(change) / std_error, np.nan)
    ax.bar(np.arange(len(names)), ratio, color=AFTER)
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(names)), labels=list(names), rotation=90, fontsize=5 if len(names) > 30 else 8)
    ax.set_ylabel("|change| / std error")
    ax.set_title("How far each estimated parameter moved, in its own uncertainty")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    return fig


def accuracy_history(
    at: Sequence[datetime], measured_mm: Sequence[float | None], predicted_mm: Sequence[float | None], marked: int
) -> Figure:
    """The robot's accuracy over its history: each calibration's and check's measured RMS error and what was
    predicted, against the event's time; the event `marked` (this calibration) ringed."""
    fig = Figure(figsize=(WIDTH_IN, 3.0))
    ax = fig.add_subplot()
    x = np.array([t.timestamp() / 86_400.0 for t in at])  # matplotlib's dates: days since 1970-01-01 UTC
    for values, color, label in ((measured_mm, BEFORE, "measured (RMS)"), (predicted_mm, AFTER, "predicted (1 σ RMS)")):
        y = np.array([np.nan if v is None else v for v in values], dtype=float)
        shown = np.isfinite(y)
        if shown.any():
            ax.plot(x[shown], y[shown], marker="o", color=color, label=label)
    if 0 <= marked < len(at) and measured_mm[marked] is not None:
        ring = [float(measured_mm[marked] or 0.0)]
        ax.plot(x[marked : marked + 1], ring, marker="o", markersize=12, fillstyle="none", color="black")
    ax.xaxis_date()
    ax.set_ylim(bottom=0)
    ax.set_ylabel("TCP error (mm)")
    ax.set_title("The robot's accuracy over its calibrations and checks (ringed: this calibration)")
    ax.legend(loc="upper left", fontsize="small")
    ax.grid(alpha=0.3)
    fig.autofmt_xdate()
    fig.tight_layout()
    return fig
