"""Statistics of pose errors, in boundary units (mm, degrees): the numbers of the JSON summary and the report.

Errors come in as (..., 6) arrays, rows dp (mm) and dω (rad); a quantity is
"position" (the first three) or "orientation" (the last three).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]

AXES: tuple[str, ...] = ("x", "y", "z")
UNITS: dict[str, tuple[str, float]] = {"position": ("mm", 1.0), "orientation": ("deg", float(np.degrees(1.0)))}
"""Per quantity: the boundary unit and the factor from internal units to it."""


def quantity_of(errors: Array, quantity: str) -> Array:
    """The position (first three) or orientation (last three) rows of (..., 6) errors."""
    return errors[..., :3] if quantity == "position" else errors[..., 3:]


def by_axis(values: Array) -> dict[str, float]:
    return {a: float(v) for a, v in zip(AXES, values, strict=True)}


def block_stats(errors: Array, quantity: str) -> dict[str, Any]:
    """Per-axis RMS, mean |·| and max |·|, and statistics of the absolute error, boundary units."""
    unit, factor = UNITS[quantity]
    flat = quantity_of(errors, quantity).reshape(-1, 3) * factor
    norms = np.linalg.norm(flat, axis=1)
    return {
        f"rms_{unit}": by_axis(np.sqrt(np.mean(flat**2, axis=0))),
        f"mean_abs_{unit}": by_axis(np.mean(np.abs(flat), axis=0)),
        f"max_abs_{unit}": by_axis(np.max(np.abs(flat), axis=0)),
        "absolute": {
            f"rms_{unit}": float(np.sqrt(np.mean(norms**2))),
            f"mean_{unit}": float(np.mean(norms)),
            f"p95_{unit}": float(np.percentile(norms, 95)),
            f"max_{unit}": float(np.max(norms)),
        },
    }


def gap_stats(gap: Array, reference: Array, quantity: str) -> dict[str, float]:
    """RMS and max of a gap's absolute value, and its RMS relative to the reference's."""
    unit, factor = UNITS[quantity]
    g = np.linalg.norm(quantity_of(gap, quantity), axis=-1) * factor
    ref_rms = float(np.sqrt(np.mean(np.sum(quantity_of(reference, quantity) ** 2, axis=-1)))) * factor
    rms = float(np.sqrt(np.mean(g**2)))
    return {f"rms_{unit}": rms, f"max_{unit}": float(np.max(g)), "relative_rms": rms / ref_rms if ref_rms > 0 else 0.0}


def json_safe(tree: Any) -> Any:
    """NaN (a share of a zero error, with zero tolerances) becomes null: strict JSON has no NaN."""
    if isinstance(tree, dict):
        return {k: json_safe(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [json_safe(v) for v in tree]
    if isinstance(tree, float) and not math.isfinite(tree):
        return None
    return tree
