"""Simulated ballbar campaigns (a known truth for the tests and the benchmark of `identify_references`), and how
their results are judged: the TCP error after the best rigid motion, and the fit's own Cramér–Rao prediction."""

from __future__ import annotations

import statistics
from dataclasses import dataclass, field

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


def aligned_errors(
    desc: RobotDescription, fit: ReferenceFit, truth: np.ndarray, fresh: np.ndarray, reference: np.ndarray
) -> dict[str, float]:
    """A fit's TCP errors at the `fresh` joints against the `truth`, each after the best rigid motion (mm): its
    own, the Cramér–Rao bound's, the nominal model's and those of the parameters `reference` (another
    estimator's), named as `SeedErrors.add` takes them."""
    true_p = forward_kinematics(desc, fresh, truth).positions
    return {
        "tcp_after": aligned_rms(forward_kinematics(desc, fresh, fit.parameters).positions, true_p),
        "bound": predicted_rms(desc, fit, fresh, stated=True),
        "nominal": aligned_rms(forward_kinematics(desc, fresh).positions, true_p),
        "reference_estimator": aligned_rms(forward_kinematics(desc, fresh, reference).positions, true_p),
    }


@dataclass
class SeedErrors:
    """A benchmark's fits, one simulated campaign (seed) after another: each one's row, and the medians over the
    seeds of its TCP error against the bound, the nominal model's and the reference estimator's."""

    rows: list[dict[str, object]] = field(default_factory=list)
    over_bound: list[float] = field(default_factory=list)
    over_nominal: list[float] = field(default_factory=list)
    over_reference: list[float] = field(default_factory=list)

    def add(self, seed: int, fit: ReferenceFit, **errors_mm: float) -> None:
        """One seed's fit and its TCP errors (mm): tcp_after, bound, nominal and reference_estimator."""
        after = errors_mm["tcp_after"]
        self.over_bound.append(after / errors_mm["bound"])
        self.over_nominal.append(after / errors_mm["nominal"])
        self.over_reference.append(after / errors_mm["reference_estimator"])
        self.rows.append(seed_row(seed, fit, **errors_mm))

    def medians(self) -> tuple[float, float, float]:
        """Over the seeds: the TCP error over the bound, over the nominal model's, over the reference's."""
        return (
            statistics.median(self.over_bound),
            statistics.median(self.over_nominal),
            statistics.median(self.over_reference),
        )

    def summary(self) -> dict[str, object]:
        """The rows as `per_seed`, then the three medians."""
        over_bound, over_nominal, over_reference = self.medians()
        return {
            "per_seed": self.rows,
            "tcp_over_bound_median": over_bound,
            "tcp_over_nominal_median": over_nominal,
            "tcp_over_reference_estimator_median": over_reference,
        }
