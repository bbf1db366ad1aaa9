"""The tolerance study: the request's magnitudes in internal units, and the frozen `ErrorAnalysisResult`
summarised as the report (statistics over poses and draws, mm and degrees)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from models._types import Array
from models.error_analysis import AXES, MODELS, SUBSYSTEMS, ErrorAnalysisResult, ErrorMagnitudes, PoseErrors
from service.schemas.error_analysis import ErrorAnalysisPublic, ErrorAnalysisRequest

DEG = math.degrees(1.0)
UNITS: dict[str, tuple[str, float]] = {"position": ("mm", 1.0), "orientation": ("deg", DEG)}
"""Boundary unit and factor from internal units, per quantity (rows 0-2 of an error are dp, 3-5 are dω)."""
CASES = (*SUBSYSTEMS, "carriage_frame")


def tolerances_in(body: ErrorAnalysisRequest) -> ErrorMagnitudes:
    return ErrorMagnitudes.from_boundary(
        leg_offset_mm=body.leg_offset_mm,
        joint_position_mm=body.joint_position_mm,
        dh_angle_deg=body.dh_angle_deg,
        dh_length_mm=body.dh_length_mm,
    )


def _part(errors: Array, quantity: str) -> Array:
    return errors[..., :3] if quantity == "position" else errors[..., 3:]


def _axes(values: Array) -> dict[str, float]:
    return dict(zip(AXES, values.tolist(), strict=True))


def _stats(errors: Array, quantity: str, worst: Array | None) -> dict[str, Any]:
    unit, factor = UNITS[quantity]
    flat = _part(errors, quantity).reshape(-1, 3) * factor
    norms = np.linalg.norm(flat, axis=1)
    out: dict[str, Any] = {
        f"rms_{unit}": _axes(np.sqrt(np.mean(flat**2, axis=0))),
        f"mean_abs_{unit}": _axes(np.mean(np.abs(flat), axis=0)),
        f"max_abs_{unit}": _axes(np.max(np.abs(flat), axis=0)),
        "absolute": {
            f"rms_{unit}": float(np.sqrt(np.mean(norms**2))),
            f"mean_{unit}": float(np.mean(norms)),
            f"p95_{unit}": float(np.percentile(norms, 95)),
            f"max_{unit}": float(np.max(norms)),
        },
    }
    if worst is not None:
        out[f"worst_case_abs_{unit}"] = _axes(worst * factor)
    return out


def _gap(gap: Array, reference: Array, quantity: str) -> dict[str, float]:
    unit, factor = UNITS[quantity]
    g = np.linalg.norm(_part(gap, quantity), axis=-1) * factor
    ref_rms = float(np.sqrt(np.mean(np.sum(_part(reference, quantity) ** 2, axis=-1)))) * factor
    rms = float(np.sqrt(np.mean(g**2)))
    return {f"rms_{unit}": rms, f"max_{unit}": float(np.max(g)), "relative_rms": rms / ref_rms if ref_rms > 0 else 0.0}


def _errors(result: ErrorAnalysisResult, case: str) -> PoseErrors:
    return result.carriage_frame if case == "carriage_frame" else result.errors[case]


def _case(result: ErrorAnalysisResult, case: str) -> dict[str, Any]:
    errors = _errors(result, case)
    out: dict[str, Any] = {}
    for model in MODELS:
        out[model] = {
            quantity: _stats(
                getattr(errors, model),
                quantity,
                getattr(result.worst_cases[case][quantity], model) if case in result.worst_cases else None,
            )
            for quantity in UNITS
        }
    out["linearisation_gap"] = {q: _gap(errors.gap, errors.exact, q) for q in UNITS}
    return out


def _per_pose(result: ErrorAnalysisResult, case: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for model in MODELS:
        errors = getattr(_errors(result, case), model)
        block: dict[str, Any] = {}
        for quantity, (unit, factor) in UNITS.items():
            absolute = result.absolute(case, model, quantity) * factor
            axes_rms = np.sqrt(np.mean(_part(errors, quantity) ** 2, axis=0)) * factor
            block[f"{quantity}_rms_{unit}"] = np.sqrt(np.mean(absolute**2, axis=0)).tolist()
            block[f"{quantity}_first_draw_{unit}"] = absolute[0].tolist()
            block[f"{quantity}_axes_rms_{unit}"] = {a: axes_rms[:, k].tolist() for k, a in enumerate(AXES)}
        out[model] = block
    return out


def report_out(result: ErrorAnalysisResult) -> ErrorAnalysisPublic:
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
    carriage_frame = _case(result, "carriage_frame")
    carriage_frame["mean_abs_ratio_to_whole"] = {q: result.mean_abs_ratio("carriage_frame", "exact", q) for q in UNITS}
    superposition = result.superposition_gap()
    tol = result.tolerances
    return ErrorAnalysisPublic.model_validate(
        {
            "robot": result.robot,
            "n_poses": result.n_poses,
            "n_draws": result.n_draws,
            "seed": result.seed,
            "distribution": result.distribution,
            "tolerances": {
                "leg_offset_mm": tol.leg_offset,
                "joint_position_mm": tol.joint_position,
                "dh_angle_deg": tol.dh_angle * DEG,
                "dh_length_mm": tol.dh_length,
            },
            "subsystems": {sub: _case(result, sub) for sub in SUBSYSTEMS},
            "carriage_frame": carriage_frame,
            "shares": shares,
            "superposition_gap": {q: _gap(superposition, result.errors["whole"].exact, q) for q in UNITS},
            "thesis_claims": result.claims(),
            "per_pose": {
                "joints": (result.joints * result.joint_to_boundary).tolist(),
                **{case: _per_pose(result, case) for case in CASES},
            },
            "seconds": result.seconds,
        }
    )
