"""A UR5-like arm calibrated without a tracker from a touch probe and sockets (issue 27): four sockets the tool
is seated in ten orientations each and two plates probed at 20 places each, σ 5 µm, every DH parameter of the
truth perturbed; five seeds.

Points and planes carry no length (a robot scaled with its points and plates fits them as well), so the fit
refuses them alone; one ballbar pivot × 20 records (σ 5 µm) gives the length, as a cell would add it.

- accuracy: the calibrated TCP error on 300 fresh poses after the best rigid alignment, against the
  Cramér–Rao bound of the same campaign and against the nominal model's error;
- an independent estimator in the same run: scipy's `least_squares` with the kinematics in plain numpy
  (`benchmarks/numpy_arm.py`) and the point, plane and distance residuals written here (a plane as a unit
  normal from two spherical angles and an offset: another parametrisation than the fit's), same unknowns,
  same start.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from benchmarks.numpy_arm import VectorisedArm
from benchmarks.timing import aligned_fit_targets
from harness.ballbar import PIVOTS, SeedErrors, aligned_errors, gauge_truth, reaching
from models import NoiseModel, forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.identification.reference_fit import ReferenceFit, identify_references
from models.measurements.references import Anchor, FixedPoint, Plane, ReferenceRecords

SIGMA_MM = 0.005
SOCKETS = np.array([[400.0, 100.0, 200.0], [-100.0, 420.0, 150.0], [250.0, -350.0, 300.0], [300.0, 300.0, 450.0]])
PLATES = ((np.array([0.0, 0.0, 1.0]), 60.0), (np.array([1.0, 0.0, 0.0]), 520.0))
SEEDS = (1, 2, 3, 4, 5)
NOISE = NoiseModel(SIGMA_MM, 1e-5)
DESC = ur5_like()


def _plate_points(normal: np.ndarray, offset: float, rng: np.random.Generator, n: int) -> np.ndarray:
    """`n` places on the plate n·p = offset spread over ±250 mm, each off it by the probe's noise."""
    e1 = np.cross(normal, [0.0, 1.0, 0.0] if abs(normal[1]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    centre = normal * offset + (np.array([250.0, 0.0, 0.0]) if normal[0] == 0 else np.array([0.0, 0.0, 300.0]))
    a, b = rng.uniform(-250, 250, (2, n))
    return np.asarray(centre + a[:, None] * e1 + b[:, None] * e2 + rng.normal(0, SIGMA_MM, n)[:, None] * normal)


def campaign(seed: int) -> tuple[np.ndarray, tuple[ReferenceRecords, ...]]:
    """(the truth, its records): where the TCP really was is the socket or plate plus the σ, and the joints
    are the true robot's there."""
    rng = np.random.default_rng(seed)
    truth = gauge_truth(DESC, seed)
    groups = []
    for k, socket in enumerate(SOCKETS):
        seated = socket + rng.normal(0, SIGMA_MM, (16, 3))
        joints = reaching(DESC, truth, seated, 10 * seed + k)[:10]
        groups.append(ReferenceRecords(FixedPoint(f"p{k + 1}", (0.0, 0.0, 0.0)), joints, np.zeros(len(joints))))
    for k, (normal, offset) in enumerate(PLATES):
        joints = reaching(DESC, truth, _plate_points(normal, offset, rng, 40), 10 * seed + 5 + k)[:20]
        side = (float(normal[0]), float(normal[1]), float(normal[2]))
        groups.append(ReferenceRecords(Plane(f"f{k + 1}", side, offset), joints, np.zeros(len(joints))))
    bar = sample_workspace(DESC, 20, seed=1000 + seed)
    reads = np.linalg.norm(forward_kinematics(DESC, bar, truth).positions - PIVOTS[0], axis=1)
    groups.append(ReferenceRecords(Anchor("a1", (0.0, 0.0, 0.0)), bar, reads + rng.normal(0, SIGMA_MM, 20)))
    return truth, tuple(groups)


def _reference_estimator(fit: ReferenceFit, groups: tuple[ReferenceRecords, ...]) -> np.ndarray:
    """scipy + numpy over the fit's robot parameters and every reference's unknowns, from the nominal robot and
    starts computed here (a centroid, a plane through the touches, a sphere): the robot parameters it finds."""
    arm = VectorisedArm(DESC)
    est = np.array(fit.estimated)
    start = DESC.parameters.nominal.copy()
    scales = DESC.parameters.scales[est]
    starts = [_start(arm.positions(g.joints, start), g) for g in groups]
    sizes = [len(s) for s in starts]
    u0 = np.concatenate(starts)

    def residuals(x: np.ndarray) -> np.ndarray:
        theta = start.copy()
        theta[est] += scales * x[: est.size]
        u, out, k = u0 + x[est.size :], [], 0
        for group, size in zip(groups, sizes, strict=True):
            v, k = u[k : k + size], k + size
            p = arm.positions(group.joints, theta)
            if isinstance(group.reference, FixedPoint):
                out.append(((p - v).ravel()) / SIGMA_MM)
            elif isinstance(group.reference, Plane):
                normal = np.array([np.sin(v[0]) * np.cos(v[1]), np.sin(v[0]) * np.sin(v[1]), np.cos(v[0])])
                out.append((p @ normal - v[2]) / SIGMA_MM)
            else:
                out.append((np.linalg.norm(p - v, axis=1) - group.values) / SIGMA_MM)
        return np.concatenate(out)

    found = scipy.optimize.least_squares(residuals, np.zeros(est.size + u0.size), method="trf", xtol=1e-12)
    theta = start.copy()
    theta[est] += scales * found.x[: est.size]
    return theta


def _start(p: np.ndarray, group: ReferenceRecords) -> np.ndarray:
    if isinstance(group.reference, FixedPoint):
        return np.asarray(p.mean(axis=0))
    if isinstance(group.reference, Plane):
        centre = p.mean(axis=0)
        normal = np.linalg.svd(p - centre)[2][2]
        normal = normal if normal @ np.asarray(group.reference.normal) > 0 else -normal
        polar, azimuth = np.arccos(np.clip(normal[2], -1, 1)), np.arctan2(normal[1], normal[0])
        return np.array([polar, azimuth, float(normal @ centre)])
    a = np.hstack([2 * p, -np.ones((p.shape[0], 1))])
    solution, *_ = np.linalg.lstsq(a, np.sum(p**2, axis=1) - group.values**2, rcond=None)
    return np.asarray(solution[:3])


def run() -> dict[str, object]:
    fresh = sample_workspace(DESC, 300, seed=999)
    errors = SeedErrors()
    for seed in SEEDS:
        truth, groups = campaign(seed)
        fit = identify_references(DESC, groups, noise=NOISE)
        errors.add(seed, fit, **aligned_errors(DESC, fit, truth, fresh, _reference_estimator(fit, groups)))
    return {
        **errors.summary(),
        "targets": aligned_fit_targets("probe + sockets", errors.medians(), (1.3, 0.3, 1.05), len(SEEDS)),
    }
