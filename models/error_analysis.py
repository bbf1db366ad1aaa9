"""The thesis's tolerance study (§4.5): how far manufacturing errors move the TCP.

For random poses inside the workspace and a Monte Carlo of parameter-error
draws within the given tolerances, the TCP pose error at the *same joint
readings* is computed three times — carriage errors alone, hexapod errors
alone, all together — and each time by two models:

- exact: forward kinematics of the perturbed robot (`forward_kinematics`
  with `nominal + δ`), compared with the nominal robot's pose;
- first order: the identification Jacobian at the nominal pose times δ.

Position errors are in mm; orientation errors are the small world-frame
rotation vector `log(R_perturbed R_nominalᵀ)` (rad inside, degrees in
`to_dict`), the same convention as the Jacobian's rotation rows, so the two
models are directly comparable and their difference is the linearisation
error, quadratic in the tolerances.

Base and tool transforms are not perturbed: the thesis's study has neither
(its world frame is the carriage's base, its TCP the platform centre), and a
calibration registers both against the instrument anyway.

Command line: `python -m models.error_analysis --help`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models.errors import CalibrationError, InvalidInput, NonFiniteValue, UnreachablePose, WrongShape
from models.iwr import iwr
from models.kinematics import ForwardResult, as_joint_array, forward_kinematics
from models.parameters import Kind
from models.robot import RobotDescription
from models.runtime import runtime_for
from models.transforms import matrix_to_rotvec_np
from models.workspace import sample_workspace

Array = NDArray[np.float64]

SUBSYSTEMS: tuple[str, ...] = ("carriage", "hexapod", "whole")
"""Which parameter errors are switched on: the carriage's, the hexapod's, or both."""
MODELS: tuple[str, ...] = ("exact", "first_order")
DISTRIBUTIONS: tuple[str, ...] = ("sign", "uniform")
AXES: tuple[str, ...] = ("x", "y", "z")

MAX_POSES = 10_000
MAX_DRAWS = 10_000
MAX_EVALUATIONS = 100_000
"""poses × draws. Each costs three perturbed FK solves (~35 µs here) and 48 stored numbers (~400 B):
the cap keeps one study under ~40 MB and ~7 s on a 2-core machine."""

NEGLIGIBLE = 1e-9
"""mm or rad: errors this small are round-off (zero tolerances), and shares of them are undefined (NaN)."""
_DRAW_STREAM = 1
"""Second word of the draws' seed, so poses (seeded by `seed` alone) do not depend on the number of draws."""
_DEG = float(np.degrees(1.0))


@dataclass(frozen=True)
class Tolerances:
    """Error magnitudes of the study, internal units (mm, rad); defaults are the thesis's (§4.5).

    Each number is the size of the error of every parameter it covers, per
    coordinate: `joint_position` applies to each of x, y, z of every base
    joint `a_i` and platform joint `b_i`. (Not `models.parameters.ParameterScales`,
    the expected error sizes that scale the identification Jacobian, although
    their defaults agree.)
    """

    leg_offset: float = 0.5
    """|δL|, mm: each leg's length offset."""
    joint_position: float = 0.1
    """|δP|, mm: each coordinate of a_i and b_i."""
    dh_angle: float = float(np.radians(0.1))
    """|Δα| = |Δθ|, rad: DH twist and joint-angle offset of every link."""
    dh_length: float = 0.5
    """|Δa| = |Δd|, mm: DH length and joint-distance offset of every link."""

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            number = math.nan if isinstance(value, bool) or not isinstance(value, int | float) else float(value)
            if not math.isfinite(number) or number < 0:
                raise InvalidInput(
                    f"tolerance {f.name} = {value!r} must be a finite number >= 0 (an error magnitude)",
                    field=f.name,
                    value=str(value),
                )

    @classmethod
    def from_boundary(
        cls,
        *,
        leg_offset_mm: float = 0.5,
        joint_position_mm: float = 0.1,
        dh_angle_deg: float = 0.1,
        dh_length_mm: float = 0.5,
    ) -> Tolerances:
        """From boundary units (mm, degrees)."""
        return cls(
            leg_offset=leg_offset_mm,
            joint_position=joint_position_mm,
            dh_angle=float(np.radians(dh_angle_deg)),
            dh_length=dh_length_mm,
        )

    def scaled(self, factor: float) -> Tolerances:
        return Tolerances(
            leg_offset=self.leg_offset * factor,
            joint_position=self.joint_position * factor,
            dh_angle=self.dh_angle * factor,
            dh_length=self.dh_length * factor,
        )

    def vector(self, desc: RobotDescription) -> Array:
        """Per-parameter error magnitude (n_params,), internal units; zero for base and tool."""
        out = np.zeros(desc.n_params)
        for i, spec in enumerate(desc.parameters.specs):
            if spec.group == "carriage":
                out[i] = self.dh_angle if spec.kind is Kind.ANGLE else self.dh_length
            elif spec.group == "hexapod":
                out[i] = self.leg_offset if spec.name.endswith(".offset") else self.joint_position
        return out

    def to_dict(self) -> dict[str, float]:
        return {
            "leg_offset_mm": float(self.leg_offset),
            "joint_position_mm": float(self.joint_position),
            "dh_angle_deg": float(self.dh_angle) * _DEG,
            "dh_length_mm": float(self.dh_length),
        }


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
class _Nominal:
    joints: Array
    positions: Array
    rotations: Array
    platforms: Array
    jacobians: Array
    carriage_frames: Array
    """(N, 4, 4) world <- carriage end frame {n}: the hexapod's base plate."""


def _nominal(desc: RobotDescription, joints: Array) -> _Nominal:
    theta0 = desc.parameters.nominal
    fk = forward_kinematics(desc, joints, theta0, jacobian=True)
    (frames,) = runtime_for(desc).kinematics.batch("carriage_fk", joints[:, : desc.n_chain], theta0)
    return _Nominal(joints, fk.positions, fk.rotations, fk.platforms, fk.jacobians, frames)


def _pose_difference(positions: Array, rotations: Array, ref_positions: Array, ref_rotations: Array) -> Array:
    """(N, 6): position difference and the world-frame rotation vector log(R R_refᵀ)."""
    return np.concatenate(
        [positions - ref_positions, matrix_to_rotvec_np(rotations @ ref_rotations.transpose(0, 2, 1))], axis=1
    )


def _perturbed_fk(
    desc: RobotDescription, nominal: _Nominal, params: Array, *, draw: int | None, pose: int | None = None
) -> ForwardResult:
    """FK of a perturbed robot at the nominal joint readings (all poses, or one); draw None = worst case."""
    rows = slice(None) if pose is None else slice(pose, pose + 1)
    try:
        # Seeded at the nominal platform poses: a few Newton steps, and the same assembly branch for sure.
        return forward_kinematics(desc, nominal.joints[rows], params, seeds=nominal.platforms[rows])
    except UnreachablePose as exc:
        where = exc.data.get("pose", 0) if pose is None else pose
        raise UnreachablePose(
            f"with these tolerances the perturbed hexapod does not assemble at pose {where} "
            f"({'worst-case signs' if draw is None else f'draw {draw}'}): "
            f"{exc.detail}. The study is meant for manufacturing tolerances (tenths of a mm or degree); "
            "use smaller tolerances",
            pose=where,
            draw=draw,
            reason=exc.data["reason"],
        ) from exc


def _pose_errors(desc: RobotDescription, nominal: _Nominal, deltas: Array) -> PoseErrors:
    theta0 = desc.parameters.nominal
    exact = np.empty((deltas.shape[0], nominal.joints.shape[0], 6))
    for k, delta in enumerate(deltas):
        fk = _perturbed_fk(desc, nominal, theta0 + delta, draw=k)
        exact[k] = _pose_difference(fk.positions, fk.rotations, nominal.positions, nominal.rotations)
    first_order = np.einsum("nkp,dp->dnk", nominal.jacobians, deltas)
    return PoseErrors(exact, first_order)


def _carriage_frame_errors(desc: RobotDescription, nominal: _Nominal, deltas: Array) -> PoseErrors:
    """Errors of the carriage's own end frame {n} (the thesis's δX0, Figs. 31-32) for carriage-only deltas.

    First order without another Jacobian: with the hexapod untouched, frame {n}
    and the TCP move as one rigid body, so they share the rotation error dω and
    dp_frame = dp_tcp − dω × (p_tcp − p_frame).
    """
    fns = runtime_for(desc).kinematics
    theta0 = desc.parameters.nominal
    q_chain = nominal.joints[:, : desc.n_chain]
    ref = nominal.carriage_frames
    exact = np.empty((deltas.shape[0], q_chain.shape[0], 6))
    for k, delta in enumerate(deltas):
        (frames,) = fns.batch("carriage_fk", q_chain, theta0 + delta)
        exact[k] = _pose_difference(frames[:, :3, 3], frames[:, :3, :3], ref[:, :3, 3], ref[:, :3, :3])
    tcp = np.einsum("nkp,dp->dnk", nominal.jacobians, deltas)
    lever = nominal.positions - ref[:, :3, 3]
    first_order = tcp.copy()
    first_order[..., :3] -= np.cross(tcp[..., 3:], lever[None, :, :])
    return PoseErrors(exact, first_order)


def pose_errors(desc: RobotDescription, joints: ArrayLike, deltas: ArrayLike) -> PoseErrors:
    """TCP errors at fixed joint readings caused by parameter errors `deltas` (D, n_params) or (n_params,).

    Joints (N, n_joints) in internal units; both models, see the module docstring.
    """
    q = as_joint_array(desc, joints)
    d = _deltas_array(desc, deltas)
    return _pose_errors(desc, _nominal(desc, q), d)


def carriage_frame_errors(desc: RobotDescription, joints: ArrayLike, deltas: ArrayLike) -> PoseErrors:
    """Errors of the carriage end frame {n} (world frame) caused by the carriage part of `deltas`."""
    q = as_joint_array(desc, joints)
    d = _deltas_array(desc, deltas) * subsystem_mask(desc, "carriage")
    return _carriage_frame_errors(desc, _nominal(desc, q), d)


def _deltas_array(desc: RobotDescription, deltas: ArrayLike) -> Array:
    d = np.atleast_2d(np.asarray(deltas, dtype=float))
    if d.ndim != 2 or d.shape[1] != desc.n_params:
        raise WrongShape(
            f"parameter errors must have {desc.n_params} numbers per draw, got shape {np.shape(deltas)}",
            field="deltas",
            expected=[-1, desc.n_params],
            got=list(np.shape(deltas)),
        )
    if not np.all(np.isfinite(d)):
        raise NonFiniteValue("parameter errors must be finite numbers", field="deltas")
    return d


def draw_errors(
    desc: RobotDescription, n_draws: int, tolerances: Tolerances, distribution: str, rng: np.random.Generator
) -> Array:
    """(n_draws, n_params) parameter errors of the whole robot (carriage and hexapod), internal units.

    The random pattern does not depend on the tolerance values, so scaling the
    tolerances scales every draw by the same factor (what the linearisation
    test relies on).
    """
    _check_distribution(distribution)
    if distribution == "sign":
        # The thesis gives magnitudes: every parameter is off by exactly its tolerance, either way.
        pattern = 2.0 * rng.integers(0, 2, size=(n_draws, desc.n_params)) - 1.0
    else:
        pattern = rng.uniform(-1.0, 1.0, size=(n_draws, desc.n_params))
    return pattern * tolerances.vector(desc)


def subsystem_mask(desc: RobotDescription, subsystem: str) -> Array:
    """1.0 on the parameters whose errors a case switches on ("carriage", "hexapod", "whole"), else 0.0."""
    if subsystem not in SUBSYSTEMS:
        raise InvalidInput(f"unknown subsystem {subsystem!r}; use one of {list(SUBSYSTEMS)}", value=subsystem)
    mask = np.zeros(desc.n_params)
    for group in ("carriage", "hexapod") if subsystem == "whole" else (subsystem,):
        mask[desc.slices[group]] = 1.0
    return mask


def _worst_cases(desc: RobotDescription, nominal: _Nominal, tol: Array) -> dict[str, dict[str, WorstCase]]:
    """The first-order stack-up bound per case, quantity and axis, and the exact error at its signs."""
    theta0 = desc.parameters.nominal
    out: dict[str, dict[str, WorstCase]] = {}
    for sub in SUBSYSTEMS:
        t = tol * subsystem_mask(desc, sub)
        out[sub] = {}
        for quantity, rows in (("position", range(3)), ("orientation", range(3, 6))):
            bound, exact = np.zeros(3), np.zeros(3)
            for k, row in enumerate(rows):
                sens = nominal.jacobians[:, row, :]
                per_pose = np.abs(sens) @ t
                n = int(np.argmax(per_pose))
                delta = np.sign(sens[n]) * t
                fk = _perturbed_fk(desc, nominal, theta0 + delta, draw=None, pose=n)
                diff = _pose_difference(
                    fk.positions, fk.rotations, nominal.positions[n : n + 1], nominal.rotations[n : n + 1]
                )
                bound[k], exact[k] = per_pose[n], abs(diff[0, row])
            out[sub][quantity] = WorstCase(bound, exact)
    return out


# ---------------------------------------------------------------- statistics

_UNITS: dict[str, tuple[str, float]] = {"position": ("mm", 1.0), "orientation": ("deg", _DEG)}


def _quantity(errors: Array, quantity: str) -> Array:
    return errors[..., :3] if quantity == "position" else errors[..., 3:]


def _by_axis(values: Array) -> dict[str, float]:
    return {a: float(v) for a, v in zip(AXES, values, strict=True)}


def _block_stats(errors: Array, quantity: str) -> dict[str, Any]:
    """Per-axis RMS, mean |·| and max |·|, and statistics of the absolute error, boundary units."""
    unit, factor = _UNITS[quantity]
    flat = _quantity(errors, quantity).reshape(-1, 3) * factor
    norms = np.linalg.norm(flat, axis=1)
    return {
        f"rms_{unit}": _by_axis(np.sqrt(np.mean(flat**2, axis=0))),
        f"mean_abs_{unit}": _by_axis(np.mean(np.abs(flat), axis=0)),
        f"max_abs_{unit}": _by_axis(np.max(np.abs(flat), axis=0)),
        "absolute": {
            f"rms_{unit}": float(np.sqrt(np.mean(norms**2))),
            f"mean_{unit}": float(np.mean(norms)),
            f"p95_{unit}": float(np.percentile(norms, 95)),
            f"max_{unit}": float(np.max(norms)),
        },
    }


def _gap_stats(gap: Array, reference: Array, quantity: str) -> dict[str, float]:
    unit, factor = _UNITS[quantity]
    g = np.linalg.norm(_quantity(gap, quantity), axis=-1) * factor
    ref_rms = float(np.sqrt(np.mean(np.sum(_quantity(reference, quantity) ** 2, axis=-1)))) * factor
    rms = float(np.sqrt(np.mean(g**2)))
    return {f"rms_{unit}": rms, f"max_{unit}": float(np.max(g)), "relative_rms": rms / ref_rms if ref_rms > 0 else 0.0}


@dataclass(frozen=True, eq=False)
class ErrorAnalysisResult:
    """Outcome of `error_analysis`: arrays in internal units (mm, rad), `to_dict` in mm and degrees."""

    robot: str
    tolerances: Tolerances
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

    def _errors(self, subsystem: str) -> PoseErrors:
        return self.carriage_frame if subsystem == "carriage_frame" else self.errors[subsystem]

    def absolute(self, subsystem: str, model: str, quantity: str) -> Array:
        """(D, N) absolute error |dp| (mm) or |dω| (rad); subsystem may also be "carriage_frame"."""
        errors = getattr(self._errors(subsystem), model)
        return np.asarray(np.linalg.norm(_quantity(errors, quantity), axis=-1))

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
        values = _quantity(getattr(self._errors(subsystem), model), quantity).reshape(-1, 3)
        return AXES[int(np.argmax(np.mean(values**2, axis=0)))]

    # ------------------------------------------------------------ boundary
    def _case_dict(self, subsystem: str) -> dict[str, Any]:
        pe = self._errors(subsystem)
        entry: dict[str, Any] = {}
        for model in MODELS:
            entry[model] = {}
            for quantity, (unit, factor) in _UNITS.items():
                block = _block_stats(getattr(pe, model), quantity)
                if subsystem in self.worst_cases:
                    worst = getattr(self.worst_cases[subsystem][quantity], model) * factor
                    block[f"worst_case_abs_{unit}"] = _by_axis(worst)
                entry[model][quantity] = block
        entry["linearisation_gap"] = {q: _gap_stats(pe.gap, pe.exact, q) for q in _UNITS}
        return entry

    def _per_pose_dict(self, subsystem: str) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for model in MODELS:
            errors = getattr(self._errors(subsystem), model)
            block: dict[str, Any] = {}
            for quantity, (unit, factor) in _UNITS.items():
                absolute = self.absolute(subsystem, model, quantity) * factor
                axes_rms = np.sqrt(np.mean(_quantity(errors, quantity) ** 2, axis=0)) * factor
                block[f"{quantity}_rms_{unit}"] = np.sqrt(np.mean(absolute**2, axis=0)).tolist()
                block[f"{quantity}_first_draw_{unit}"] = absolute[0].tolist()
                block[f"{quantity}_axes_rms_{unit}"] = {a: axes_rms[:, k].tolist() for k, a in enumerate(AXES)}
            out[model] = block
        return out

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

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary in mm and degrees: statistics per case, shares, claims, per-pose values."""
        shares = {
            model: {
                quantity: {
                    sub: {
                        "mean_abs_ratio": self.mean_abs_ratio(sub, model, quantity),
                        "variance_share": self.variance_share(sub, model, quantity),
                    }
                    for sub in ("carriage", "hexapod")
                }
                for quantity in _UNITS
            }
            for model in MODELS
        }
        gap = self.superposition_gap()
        superposition = {q: _gap_stats(gap, self.errors["whole"].exact, q) for q in _UNITS}
        carriage_frame = self._case_dict("carriage_frame")
        carriage_frame["mean_abs_ratio_to_whole"] = {
            q: self.mean_abs_ratio("carriage_frame", "exact", q) for q in _UNITS
        }
        per_pose: dict[str, Any] = {"joints": (self.joints * self.joint_to_boundary).tolist()}
        per_pose.update({sub: self._per_pose_dict(sub) for sub in (*SUBSYSTEMS, "carriage_frame")})
        return _json_safe(
            {
                "robot": self.robot,
                "n_poses": self.n_poses,
                "n_draws": self.n_draws,
                "seed": self.seed,
                "distribution": self.distribution,
                "tolerances": self.tolerances.to_dict(),
                "subsystems": {sub: self._case_dict(sub) for sub in SUBSYSTEMS},
                "carriage_frame": carriage_frame,
                "shares": shares,
                "superposition_gap": superposition,
                "thesis_claims": self.claims(),
                "per_pose": per_pose,
                "seconds": self.seconds,
            }
        )


def _json_safe(tree: Any) -> Any:
    """NaN (a share of a zero error, with zero tolerances) becomes null: strict JSON has no NaN."""
    if isinstance(tree, dict):
        return {k: _json_safe(v) for k, v in tree.items()}
    if isinstance(tree, list):
        return [_json_safe(v) for v in tree]
    if isinstance(tree, float) and not math.isfinite(tree):
        return None
    return tree


# ------------------------------------------------------------------ entry points


def _check_distribution(distribution: str) -> None:
    if distribution not in DISTRIBUTIONS:
        raise InvalidInput(
            f"unknown error distribution {distribution!r}; use one of {list(DISTRIBUTIONS)}",
            field="distribution",
            value=str(distribution),
            allowed=list(DISTRIBUTIONS),
        )


def _check_count(name: str, value: int, limit: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= limit:
        raise InvalidInput(
            f"{name} = {value!r} must be a whole number between 1 and {limit}",
            field=name,
            value=str(value),
            min=1,
            max=limit,
        )


def error_analysis(
    desc: RobotDescription,
    *,
    n_poses: int = 40,
    n_draws: int = 200,
    tolerances: Tolerances = Tolerances(),
    distribution: str = "sign",
    seed: int = 0,
) -> ErrorAnalysisResult:
    """The tolerance study: n_poses random workspace poses × n_draws error draws, three cases, two models.

    Poses are `sample_workspace(desc, n_poses, seed)`; the draws come from their
    own stream, so the same seed gives the same poses whatever `n_draws`.
    """
    _check_count("n_poses", n_poses, MAX_POSES)
    _check_count("n_draws", n_draws, MAX_DRAWS)
    if n_poses * n_draws > MAX_EVALUATIONS:
        raise InvalidInput(
            f"n_poses × n_draws = {n_poses * n_draws} exceeds {MAX_EVALUATIONS}; use fewer poses or draws",
            field="n_draws",
            value=n_poses * n_draws,
            max=MAX_EVALUATIONS,
        )
    _check_distribution(distribution)
    if not isinstance(tolerances, Tolerances):
        raise InvalidInput("tolerances must be a Tolerances value", field="tolerances")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInput(f"seed = {seed!r} must be a whole number >= 0", field="seed", value=str(seed))

    started = time.perf_counter()
    joints = sample_workspace(desc, n_poses, int(seed))
    assert isinstance(joints, np.ndarray)
    nominal = _nominal(desc, joints)
    deltas = draw_errors(desc, n_draws, tolerances, distribution, np.random.default_rng((int(seed), _DRAW_STREAM)))
    masks = {sub: subsystem_mask(desc, sub) for sub in SUBSYSTEMS}
    tol = tolerances.vector(desc)
    return ErrorAnalysisResult(
        robot=desc.name,
        tolerances=tolerances,
        distribution=distribution,
        seed=int(seed),
        joints=joints,
        joint_to_boundary=desc.joint_to_boundary,
        deltas=deltas,
        tolerance_vector=tol,
        masks=masks,
        jacobians=nominal.jacobians,
        errors={sub: _pose_errors(desc, nominal, deltas * masks[sub]) for sub in SUBSYSTEMS},
        carriage_frame=_carriage_frame_errors(desc, nominal, deltas * masks["carriage"]),
        worst_cases=_worst_cases(desc, nominal, tol),
        seconds=time.perf_counter() - started,
    )


# -------------------------------------------------------------------- summary


def summary(result: ErrorAnalysisResult) -> str:
    """A readable report of the study (mm, degrees)."""
    tol = result.tolerances.to_dict()
    lines = [
        f"Error analysis of {result.robot}: {result.n_poses} poses x {result.n_draws} draws "
        f"({result.distribution} errors, seed {result.seed}, {result.seconds:.2f} s)",
        f"tolerances: |dL| = {tol['leg_offset_mm']:g} mm, |dP| = {tol['joint_position_mm']:g} mm, "
        f"|d alpha| = |d theta| = {tol['dh_angle_deg']:g} deg, |d a| = |d d| = {tol['dh_length_mm']:g} mm",
        "",
    ]
    cases = (*SUBSYSTEMS, "carriage_frame")
    labels = {"carriage_frame": "carriage {4}", "first_order": "first order"}
    for quantity, (unit, factor) in _UNITS.items():
        lines.append(
            f"{quantity} error ({unit}){'':<12}  RMS x    RMS y    RMS z    |e| mean |e| RMS  |e| max   gap RMS"
        )
        for sub in cases:
            pe = result._errors(sub)
            for model in MODELS:
                e = _quantity(getattr(pe, model), quantity).reshape(-1, 3) * factor
                norms = np.linalg.norm(e, axis=1)
                rms = np.sqrt(np.mean(e**2, axis=0))
                gap = np.sqrt(np.mean(np.sum(_quantity(pe.gap, quantity) ** 2, axis=-1))) * factor
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


# ---------------------------------------------------------------- command line


def _parser() -> argparse.ArgumentParser:
    defaults = Tolerances().to_dict()
    parser = argparse.ArgumentParser(
        prog="python -m models.error_analysis",
        description="The thesis's tolerance study (§4.5) on the IWR: TCP errors of the carriage, the hexapod "
        "and the whole robot, exact and first-order.",
    )
    parser.add_argument("--poses", type=int, default=40, help="random workspace poses (default 40)")
    parser.add_argument("--draws", type=int, default=200, help="Monte Carlo draws of the errors (default 200)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--distribution", default="sign", help=f"one of {', '.join(DISTRIBUTIONS)} (default sign)")
    parser.add_argument("--leg-offset-mm", type=float, default=defaults["leg_offset_mm"])
    parser.add_argument("--joint-position-mm", type=float, default=defaults["joint_position_mm"])
    parser.add_argument("--dh-angle-deg", type=float, default=defaults["dh_angle_deg"])
    parser.add_argument("--dh-length-mm", type=float, default=defaults["dh_length_mm"])
    parser.add_argument("--plot", type=Path, help="write the per-pose absolute errors (Figs. 37-38) to this PNG/SVG")
    parser.add_argument("--plot-axes", type=Path, help="write the per-axis errors (Figs. 31-36) to this PNG/SVG")
    parser.add_argument("--json", type=Path, help="write the JSON summary (mm, deg) to this file")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    try:
        tolerances = Tolerances.from_boundary(
            leg_offset_mm=args.leg_offset_mm,
            joint_position_mm=args.joint_position_mm,
            dh_angle_deg=args.dh_angle_deg,
            dh_length_mm=args.dh_length_mm,
        )
        result = error_analysis(
            iwr(),
            n_poses=args.poses,
            n_draws=args.draws,
            tolerances=tolerances,
            distribution=args.distribution,
            seed=args.seed,
        )
    except CalibrationError as exc:
        print(f"error: {exc.detail}", file=sys.stderr)
        return 2
    print(summary(result))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(result.to_dict(), indent=1) + "\n")
        print(f"\nwrote {args.json}")
    if args.plot or args.plot_axes:
        from models.error_analysis_plot import plot_absolute, plot_axes

        if args.plot:
            plot_absolute(result, args.plot)
            print(f"wrote {args.plot}")
        if args.plot_axes:
            plot_axes(result, args.plot_axes)
            print(f"wrote {args.plot_axes}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
