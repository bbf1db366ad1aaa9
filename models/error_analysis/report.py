"""The tolerance study as readable text (mm, degrees)."""

from __future__ import annotations

import numpy as np

from models.error_analysis.export import magnitudes_json
from models.error_analysis.result import MODELS, SUBSYSTEMS, ErrorAnalysisResult
from models.error_analysis.statistics import UNITS, quantity_of


def summary(result: ErrorAnalysisResult) -> str:
    """A readable report of the study (mm, degrees)."""
    tol = magnitudes_json(result.tolerances)
    lines = [
        f"Error analysis of {result.robot}: {result.n_poses} poses x {result.n_draws} draws "
        f"({result.distribution} errors, seed {result.seed}, {result.seconds:.2f} s)",
        f"tolerances: |dL| = {tol['leg_offset_mm']:g} mm, |dP| = {tol['joint_position_mm']:g} mm, "
        f"|d alpha| = |d theta| = {tol['dh_angle_deg']:g} deg, |d a| = |d d| = {tol['dh_length_mm']:g} mm",
        "",
    ]
    cases = (*SUBSYSTEMS, "carriage_frame")
    labels = {"carriage_frame": "carriage {4}", "first_order": "first order"}
    for quantity, (unit, factor) in UNITS.items():
        lines.append(
            f"{quantity} error ({unit}){'':<12}  RMS x    RMS y    RMS z    |e| mean |e| RMS  |e| max   gap RMS"
        )
        for sub in cases:
            pe = result.case_errors(sub)
            for model in MODELS:
                e = quantity_of(getattr(pe, model), quantity).reshape(-1, 3) * factor
                norms = np.linalg.norm(e, axis=1)
                rms = np.sqrt(np.mean(e**2, axis=0))
                gap = np.sqrt(np.mean(np.sum(quantity_of(pe.gap, quantity) ** 2, axis=-1))) * factor
                name = labels.get(sub, sub) if model == "exact" else ""
                lines.append(
                    f"  {name:<13}{labels.get(model, model):<12}"
                    + "".join(f"{v:9.4f}" for v in (*rms, norms.mean(), np.sqrt(np.mean(norms**2)), norms.max()))
                    + (f"{gap:10.2e}" if model == "first_order" else "")
                )
        lines.append("")
    claims = result.claims()
    lines += [
        "shares of the whole robot's error (exact model)     position  orientation",
        "  carriage  mean |e| / mean |e_whole|             "
        f"{claims['carriage_mean_abs_ratio_position']:8.1%}  {claims['carriage_mean_abs_ratio_orientation']:8.1%}",
        "  carriage  share of the variance                 "
        f"{claims['carriage_variance_share_position']:8.1%}  {claims['carriage_variance_share_orientation']:8.1%}",
        "  hexapod   mean |e| / mean |e_whole|             "
        f"{result.mean_abs_ratio('hexapod', 'exact', 'position'):8.1%}  "
        f"{result.mean_abs_ratio('hexapod', 'exact', 'orientation'):8.1%}",
        "  carriage frame {4} (thesis's definition)        "
        f"{claims['carriage_frame_mean_abs_ratio_position']:8.1%}  "
        f"{result.mean_abs_ratio('carriage_frame', 'exact', 'orientation'):8.1%}",
        "",
        "thesis's claims",
        f"  carriage ~80 % of the error: {claims['carriage_mean_abs_ratio_position']:.0%} at the TCP, "
        f"{claims['carriage_frame_mean_abs_ratio_position']:.0%} with the carriage's own end frame",
        f"  Z errors dominant: largest RMS position axis is {claims['dominant_position_axis']['whole']} "
        f"(carriage {claims['dominant_position_axis']['carriage']}, "
        f"hexapod {claims['dominant_position_axis']['hexapod']})",
        f"  under 10 mm: max |e| over all draws {claims['max_position_error_mm']:.2f} mm; "
        f"tolerance stack-up worst case along one axis {claims['worst_case_position_axis_error_mm']:.2f} mm",
    ]
    return "\n".join(lines)
