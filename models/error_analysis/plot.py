"""Figures of the tolerance study, like the thesis's Figs. 31-38.

matplotlib is imported inside the functions, with the non-interactive Agg
backend: importing `models` never pulls in a GUI toolkit, and a server or CI
without a display can still write the files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from models.error_analysis.export import magnitudes_json
from models.error_analysis.result import MODELS, SUBSYSTEMS, ErrorAnalysisResult
from models.error_analysis.statistics import AXES, UNITS

_COLOURS = {"carriage": "tab:blue", "hexapod": "tab:orange", "whole": "tab:green", "carriage_frame": "tab:purple"}
_LABELS = {"carriage": "carriage", "hexapod": "hexapod", "whole": "whole robot", "carriage_frame": "carriage frame {4}"}
_QUANTITIES = tuple((quantity, unit, factor) for quantity, (unit, factor) in UNITS.items())


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _title(result: ErrorAnalysisResult) -> str:
    tol = magnitudes_json(result.tolerances)
    return (
        f"{result.robot}: {result.n_poses} poses, {result.n_draws} draws ({result.distribution}); "
        f"|δL| {tol['leg_offset_mm']:g} mm, |δP| {tol['joint_position_mm']:g} mm, "
        f"|Δα|=|Δθ| {tol['dh_angle_deg']:g}°, |Δa|=|Δd| {tol['dh_length_mm']:g} mm"
    )


def _label(ax: Any, title: str, ylabel: str, *, bottom: bool) -> None:
    ax.set_title(title)
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if bottom:  # the rows share their x axis: only the bottom one names it
        ax.set_xlabel("pose")


def _finish(plt: Any, fig: Any, axes: Any, result: ErrorAnalysisResult, path: Path) -> Path:
    """One legend (every panel has the same lines), the study as title, the file written and the figure freed."""
    axes[0, 0].legend(fontsize=8, ncol=2)
    fig.suptitle(_title(result), fontsize=10)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_absolute(result: ErrorAnalysisResult, path: str | Path) -> Path:
    """Per-pose absolute position and orientation errors of carriage, hexapod and whole robot (Figs. 37-38).

    Left: the first draw (what the thesis plots, one set of errors); right:
    the RMS over all draws at each pose. Solid lines with dots: exact model;
    dashed lines with crosses: first-order model. The dotted line is the
    carriage's own end-frame error, the quantity the thesis's "carriage"
    curves show.
    """
    plt = _pyplot()
    out = Path(path)
    poses = np.arange(1, result.n_poses + 1)
    fig, axes = plt.subplots(2, 2, figsize=(13, 8), sharex=True, layout="constrained")
    for row, (quantity, unit, factor) in enumerate(_QUANTITIES):
        for col, how in enumerate(("first draw", "RMS over draws")):
            ax = axes[row, col]
            for sub in (*SUBSYSTEMS, "carriage_frame"):
                for model in MODELS if sub != "carriage_frame" else ("exact",):
                    if how == "first draw":
                        values = result.absolute(sub, model, quantity)[0]
                    else:
                        values = result.per_pose_rms(sub, model, quantity)
                    exact = model == "exact"
                    ax.plot(
                        poses,
                        values * factor,
                        color=_COLOURS[sub],
                        linestyle=(":" if sub == "carriage_frame" else "-") if exact else "--",
                        marker="o" if exact else "x",
                        markersize=4 if exact else 6,
                        linewidth=1.2 if exact else 0.9,
                        label=f"{_LABELS[sub]}, {'exact' if exact else 'first order'}",
                    )
            _label(ax, f"absolute {quantity} error, {how}", f"|error| ({unit})", bottom=row == 1)
    return _finish(plt, fig, axes, result, out)


def plot_axes(result: ErrorAnalysisResult, path: str | Path) -> Path:
    """Per-axis errors at each pose for the first draw, per case (Figs. 31-36): x, y, z of position
    (top row) and orientation (bottom row); exact solid, first order dashed."""
    plt = _pyplot()
    out = Path(path)
    poses = np.arange(1, result.n_poses + 1)
    fig, axes = plt.subplots(2, 3, figsize=(15, 7.5), sharex=True, layout="constrained")
    colours = dict(zip(AXES, ("tab:red", "tab:green", "tab:blue"), strict=True))
    for row, (quantity, unit, factor) in enumerate(_QUANTITIES):
        rows = slice(0, 3) if quantity == "position" else slice(3, 6)
        for col, sub in enumerate(SUBSYSTEMS):
            ax = axes[row, col]
            for model in MODELS:
                values = getattr(result.errors[sub], model)[0, :, rows] * factor
                for k, axis in enumerate(AXES):
                    exact = model == "exact"
                    ax.plot(
                        poses,
                        values[:, k],
                        color=colours[axis],
                        linestyle="-" if exact else "--",
                        marker="o" if exact else "x",
                        markersize=3.5 if exact else 5,
                        linewidth=1.1 if exact else 0.8,
                        label=f"{axis}, {'exact' if exact else 'first order'}",
                    )
            ax.axhline(0.0, color="black", linewidth=0.5)
            title = f"{quantity} error of the {_LABELS[sub]} (first draw)"
            _label(ax, title, f"{quantity} error ({unit})", bottom=row == 1)
    return _finish(plt, fig, axes, result, out)
