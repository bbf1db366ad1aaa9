"""The outcome of the tolerance study: pose errors per case and model, and the shares derived from them.

Arrays in internal units (mm, rad); `models.error_analysis.export` writes the command line's JSON file in mm
and degrees (the HTTP service builds its own answer in `service.conversions`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from models.error_analysis.magnitudes import ErrorMagnitudes
from models.error_analysis.statistics import (
    AXES,
    Array,
    quantity_of,
)

SUBSYSTEMS: tuple[str, ...] = ("carriage", "hexapod", "whole")
"""Which parameter errors are switched on: the carriage's, the hexapod's, or both."""
MODELS: tuple[str, ...] = ("exact", "first_order")

NEGLIGIBLE = 1e-9
"""mm or rad: errors this small are round-off (zero tolerances), and shares of them are undefined (NaN)."""


@dataclass(frozen=True, eq=False)
class PoseErrors:
    """Pose errors for D parameter-error draws at N poses: rows dp (mm), dω (rad), world frame."""

    exact: Array
    """(D, N, 6) perturbed FK minus nominal FK."""
    first_order: Array
    """(D, N, 6) Jacobian × δ."""

    @property
    def gap(self) -> Array:
        """(D, N, 6) exact minus first order: the linearisation error."""
        return self.exact - self.first_order


@dataclass(frozen=True, eq=False)
class WorstCase:
    """Per-axis worst case over the poses of one error case: every parameter at ± its tolerance, signs
    chosen to push one axis of one pose as far as possible (the first-order tolerance stack-up)."""

    first_order: Array
    """(3,) max over poses of Σ_j |J_kj| tol_j (mm or rad)."""
    exact: Array
    """(3,) |exact error| along that axis at the same pose and signs."""


@dataclass(frozen=True, eq=False)
class ErrorAnalysisResult:
    """Outcome of `error_analysis`: arrays in internal units (mm, rad)."""

    robot: str
    tolerances: ErrorMagnitudes
    distribution: str
    seed: int
    joints: Array
    """(N, n_joints) the poses, internal units."""
    joint_to_boundary: Array
    deltas: Array
    """(D, n_params) each draw's parameter errors (whole robot); a subsystem case keeps its own part."""
    tolerance_vector: Array
    """(n_params,) per-parameter error magnitude, internal units."""
    masks: dict[str, Array]
    """Per case: 1.0 on the parameters whose errors it switches on."""
    jacobians: Array
    """(N, 6, n_params) identification Jacobians at the nominal poses."""
    errors: dict[str, PoseErrors]
    """TCP errors per case ("carriage", "hexapod", "whole")."""
    carriage_frame: PoseErrors
    """The carriage end frame's own errors from the carriage's errors (the thesis's "carriage" curves)."""
    worst_cases: dict[str, dict[str, WorstCase]]
    """Per case, per quantity ("position", "orientation")."""
    seconds: float

    @property
    def n_poses(self) -> int:
        return int(self.joints.shape[0])

    @property
    def n_draws(self) -> int:
        return int(self.deltas.shape[0])

    def case_errors(self, subsystem: str) -> PoseErrors:
        """The errors of one case: a subsystem, "whole" or "carriage_frame"."""
        return self.carriage_frame if subsystem == "carriage_frame" else self.errors[subsystem]

    def absolute(self, subsystem: str, model: str, quantity: str) -> Array:
        """(D, N) absolute error |dp| (mm) or |dω| (rad); subsystem may also be "carriage_frame"."""
        errors = getattr(self.case_errors(subsystem), model)
        return np.asarray(np.linalg.norm(quantity_of(errors, quantity), axis=-1))

    def per_pose_rms(self, subsystem: str, model: str, quantity: str) -> Array:
        """(N,) RMS over the draws of the absolute error at each pose (mm or rad)."""
        return np.asarray(np.sqrt(np.mean(self.absolute(subsystem, model, quantity) ** 2, axis=0)))

    def mean_abs_ratio(self, subsystem: str, model: str, quantity: str) -> float:
        """mean |e_subsystem| / mean |e_whole| over poses and draws: the thesis's way of sharing the error."""
        whole = float(np.mean(self.absolute("whole", model, quantity)))
        return float(np.mean(self.absolute(subsystem, model, quantity))) / whole if whole > NEGLIGIBLE else math.nan

    def variance_share(self, subsystem: str, model: str, quantity: str) -> float:
        """mean |e_sub|² / (mean |e_carriage|² + mean |e_hexapod|²): shares that add up to one.

        The draws are independent and zero-mean, so to first order the two mean
        squares add up to the whole robot's: this is the fraction of the
        whole's error variance that the subsystem causes.
        """
        ms = {s: float(np.mean(self.absolute(s, model, quantity) ** 2)) for s in ("carriage", "hexapod")}
        total = ms["carriage"] + ms["hexapod"]
        return ms[subsystem] / total if total > NEGLIGIBLE**2 else math.nan

    def superposition_gap(self) -> Array:
        """(D, N, 6) exact whole minus (exact carriage + exact hexapod): what is not additive."""
        e = self.errors
        return e["whole"].exact - e["carriage"].exact - e["hexapod"].exact

    def dominant_axis(self, subsystem: str = "whole", model: str = "exact", quantity: str = "position") -> str:
        """The axis with the largest RMS error."""
        values = quantity_of(getattr(self.case_errors(subsystem), model), quantity).reshape(-1, 3)
        return AXES[int(np.argmax(np.mean(values**2, axis=0)))]

    def claims(self) -> dict[str, Any]:
        """The thesis's three findings, measured here (exact model)."""
        whole = self.absolute("whole", "exact", "position")
        worst = float(np.max(self.worst_cases["whole"]["position"].exact))
        return {
            "carriage_frame_mean_abs_ratio_position": self.mean_abs_ratio("carriage_frame", "exact", "position"),
            "carriage_mean_abs_ratio_position": self.mean_abs_ratio("carriage", "exact", "position"),
            "carriage_variance_share_position": self.variance_share("carriage", "exact", "position"),
            "carriage_mean_abs_ratio_orientation": self.mean_abs_ratio("carriage", "exact", "orientation"),
            "carriage_variance_share_orientation": self.variance_share("carriage", "exact", "orientation"),
            "dominant_position_axis": {s: self.dominant_axis(s) for s in (*SUBSYSTEMS, "carriage_frame")},
            "max_position_error_mm": float(np.max(whole)),
            "median_over_draws_of_max_position_error_mm": float(np.median(whole.max(axis=1))),
            "worst_case_position_axis_error_mm": worst,
            "position_error_under_10_mm": bool(np.max(whole) < 10.0),
            "worst_case_under_10_mm": bool(worst < 10.0),
        }
