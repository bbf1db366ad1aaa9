"""Simulated ballbar campaigns (a known truth for the tests and the benchmark of `identify_references`), and how
their results are judged: the TCP error after the best rigid motion, and the fit's own Cramér–Rao prediction."""

from __future__ import annotations

import numpy as np

from models import RobotDescription, forward_kinematics, sample_workspace
from models.identification.reference_fit import ReferenceFit
from models.identification.registration import rigid_fit
from models.inverse import inverse_kinematics
from models.measurements.references import Anchor, ReferenceRecords
from models.simulation import perturbed_robot
from models.transforms import matrix_to_quaternion, rotvec_to_matrix_np

PIVOTS = np.array([[450.0, 150.0, 50.0], [-150.0, 450.0, 250.0], [200.0, -400.0, 400.0]])
"""Three pivots around a UR5-sized working volume (mm), none on a line with the others."""


def gauge_truth(desc: RobotDescription, seed: int) -> np.ndarray:
    """A perturbed robot whose base is the nominal one: the gauge reference records leave free, so that the
    truth and the fit can be compared in one frame."""
    truth = perturbed_robot(desc, seed=seed).truth.copy()
    truth[desc.slices["base"]] = desc.parameters.nominal[desc.slices["base"]]
    return truth


def ballbar_campaign(
    desc: RobotDescription,
    seed: int,
    *,
    per_pivot: int = 36,
    sigma_mm: float = 0.002,
    offset_mm: float = 0.35,
    pivots: np.ndarray = PIVOTS,
) -> tuple[np.ndarray, tuple[ReferenceRecords, ...]]:
    """(the truth, its records): `per_pivot` random poses a pivot, distances with noise σ; the last bar's length
    is off by `offset_mm` and marked unknown. The pivots' guesses are wrong by centimetres, as a tape's are."""
    rng = np.random.default_rng(seed)
    truth = gauge_truth(desc, seed)
    groups = []
    for k, pivot in enumerate(pivots):
        joints = sample_workspace(desc, per_pivot, seed=100 * seed + k)
        unknown = k == len(pivots) - 1
        d = np.linalg.norm(forward_kinematics(desc, joints, truth).positions - pivot, axis=1)
        d = d - (offset_mm if unknown else 0.0) + rng.normal(0, sigma_mm, per_pivot)
        gx, gy, gz = (float(v) for v in pivot + rng.normal(0, 20, 3))
        sigma = np.full(per_pivot, sigma_mm)
        groups.append(ReferenceRecords(Anchor(f"a{k + 1}", (gx, gy, gz), length_unknown=unknown), joints, d, sigma))
    return truth, tuple(groups)


def reaching(desc: RobotDescription, truth: np.ndarray, positions: np.ndarray, seed: int) -> np.ndarray:
    """Joints of the true robot with its TCP at `positions` (a socket's point, a plate's touches) in random
    tool-down orientations; only the reachable ones."""
    rng = np.random.default_rng(seed)
    rotations = [rotvec_to_matrix_np(rng.normal(0, 0.6, 3)) @ np.diag([1.0, -1.0, -1.0]) for _ in positions]
    answer = inverse_kinematics(desc, positions, matrix_to_quaternion(np.array(rotations)), truth)
    return np.asarray(answer.joints[answer.reachable])


def aligned_rms(fitted: np.ndarray, true: np.ndarray) -> float:
    """RMS TCP error after the best rigid motion: what records that fix no frame can be judged by."""
    aligned = rigid_fit(fitted, true).apply(fitted)
    return float(np.sqrt(np.mean(np.sum((aligned - true) ** 2, axis=1))))


def predicted_rms(desc: RobotDescription, fit: ReferenceFit, joints: np.ndarray, *, stated: bool = False) -> float:
    """The fit's prediction of its TCP error at `joints`: its covariance through the TCP position rows (at the
    stated σ, the variance factor taken out, when `stated`: the Cramér–Rao bound)."""
    est = np.array(fit.estimated)
    jac = forward_kinematics(desc, joints, fit.parameters, jacobian=True).jacobians[:, :3, est]
    cov = fit.parameter_covariance / (fit.covariance.variance_factor if stated else 1.0)
    return float(np.sqrt(np.mean(np.einsum("nip,pq,niq->n", jac, cov, jac))))


def seed_row(seed: int, fit: ReferenceFit, **errors_mm: float) -> dict[str, object]:
    """A benchmark's row for one simulated campaign: its TCP errors (`name=mm`, reported as `name_um`) and what
    the fit said of itself."""
    return {
        "seed": seed,
        **{f"{name}_um": 1e3 * value for name, value in errors_mm.items()},
        "variance_factor": fit.covariance.variance_factor,
        "estimated": len(fit.estimated),
        "unidentifiable": list(fit.unidentifiable),
    }
