"""The command line's JSON file of a tolerance study, in mm and degrees (the only unit conversion of the study).

The file `python -m models.error_analysis --json` writes, and the body of the HTTP service's answer
(`service.conversions.error_analysis`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models.error_analysis.magnitudes import ErrorMagnitudes
from models.error_analysis.result import MODELS, SUBSYSTEMS, ErrorAnalysisResult
from models.error_analysis.statistics import AXES, UNITS, block_stats, by_axis, gap_stats, json_safe, quantity_of


def magnitudes_json(magnitudes: ErrorMagnitudes) -> dict[str, float]:
    return {
        "leg_offset_mm": float(magnitudes.leg_offset),
        "joint_position_mm": float(magnitudes.joint_position),
        "dh_angle_deg": math.degrees(magnitudes.dh_angle),
        "dh_length_mm": float(magnitudes.dh_length),
    }


def case_json(result: ErrorAnalysisResult, subsystem: str) -> dict[str, Any]:
    pe = result.case_errors(subsystem)
    entry: dict[str, Any] = {}
    for model in MODELS:
        entry[model] = {}
        for quantity, (unit, factor) in UNITS.items():
            block = block_stats(getattr(pe, model), quantity)
            if subsystem in result.worst_cases:
                worst = getattr(result.worst_cases[subsystem][quantity], model) * factor
                block[f"worst_case_abs_{unit}"] = by_axis(worst)
            entry[model][quantity] = block
    entry["linearisation_gap"] = {q: gap_stats(pe.gap, pe.exact, q) for q in UNITS}
    return entry


def per_pose_json(result: ErrorAnalysisResult, subsystem: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for model in MODELS:
        errors = getattr(result.case_errors(subsystem), model)
        block: dict[str, Any] = {}
        for quantity, (unit, factor) in UNITS.items():
            absolute = result.absolute(subsystem, model, quantity) * factor
            axes_rms = np.sqrt(np.mean(quantity_of(errors, quantity) ** 2, axis=0)) * factor
            block[f"{quantity}_rms_{unit}"] = np.sqrt(np.mean(absolute**2, axis=0)).tolist()
            block[f"{quantity}_first_draw_{unit}"] = absolute[0].tolist()
            block[f"{quantity}_axes_rms_{unit}"] = {a: axes_rms[:, k].tolist() for k, a in enumerate(AXES)}
        out[model] = block
    return out


def result_json(result: ErrorAnalysisResult) -> dict[str, Any]:
    """JSON-ready summary in mm and degrees: statistics per case, shares, claims, per-pose values."""
    shares = {
        model: {
            quantity: {
                sub: {
                    "mean_abs_ratio": result.mean_abs_ratio(sub, model, quantity),
                    "variance_share": result.variance_share(sub, model, quantity),
                }
                for sub in ("carriage", "hexapod")
            }
            for quantity in UNITS
        }
        for model in MODELS
    }
    gap = result.superposition_gap()
    superposition = {q: gap_stats(gap, result.errors["whole"].exact, q) for q in UNITS}
    carriage_frame = case_json(result, "carriage_frame")
    carriage_frame["mean_abs_ratio_to_whole"] = {q: result.mean_abs_ratio("carriage_frame", "exact", q) for q in UNITS}
    per_pose: dict[str, Any] = {"joints": (result.joints * result.joint_to_boundary).tolist()}
    per_pose.update({sub: per_pose_json(result, sub) for sub in (*SUBSYSTEMS, "carriage_frame")})
    summary: dict[str, Any] = json_safe(
        {
            "robot": result.robot,
            "n_poses": result.n_poses,
            "n_draws": result.n_draws,
            "seed": result.seed,
            "distribution": result.distribution,
            "tolerances": magnitudes_json(result.tolerances),
            "subsystems": {sub: case_json(result, sub) for sub in SUBSYSTEMS},
            "carriage_frame": carriage_frame,
            "shares": shares,
            "superposition_gap": superposition,
            "thesis_claims": result.claims(),
            "per_pose": per_pose,
            "seconds": result.seconds,
        }
    )
    return summary
