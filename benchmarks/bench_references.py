"""A UR5-like arm calibrated from a ballbar (issue 27): three pivots × 36 records, σ 2 µm, one bar's length offset
unknown, every DH parameter of the truth perturbed; five seeds.

- accuracy: the calibrated model's TCP error on 300 fresh poses after the best rigid alignment (distances fix no
  frame) against the Cramér–Rao bound of the same campaign (the covariance of the fit's unknowns at the stated
  σ, propagated to those poses), and against the nominal model's error;
- an independent reference estimator in the same run: scipy's `least_squares` ('trf', finite-difference
  Jacobian) on the same records with the kinematics written in plain numpy (`benchmarks/numpy_arm.py`) and the
  distance residual written here, over the same unknowns from the same start: the two must agree;
- time: `identify_references` warm, against `identify` on a tracker campaign of as many position records;
- design: 30 records chosen among 150 candidate poses per pivot (I criterion), their predicted TCP error
  against the median of random sets of 30 of the same candidates.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import scipy.optimize

from benchmarks.numpy_arm import VectorisedArm
from benchmarks.timing import aligned_fit_targets, target
from harness.ballbar import SeedErrors, aligned_errors, ballbar_campaign
from models import NoiseModel, sample_workspace
from models.description.examples import ur5_like
from models.identification import identify
from models.identification.reference_fit import ReferenceFit, identify_references
from models.kinematics import ForwardResult
from models.measurements.references import Anchor, ReferenceRecords
from models.simulation import measure, perturbed_robot
from optimal_design.references import design_reference_records

SIGMA_MM = 0.002
PER_ANCHOR = 36
ANCHORS = np.array([[450.0, 150.0, 50.0], [-150.0, 450.0, 250.0], [200.0, -400.0, 400.0]])
DELTA_MM = 0.35
SEEDS = (1, 2, 3, 4, 5)
NOISE = NoiseModel(SIGMA_MM, 1e-5)
DESC = ur5_like()


def _campaign(seed: int) -> tuple[np.ndarray, tuple[ReferenceRecords, ...]]:
    return ballbar_campaign(DESC, seed, per_pivot=PER_ANCHOR, sigma_mm=SIGMA_MM, offset_mm=DELTA_MM, pivots=ANCHORS)


def _positions_only(p: np.ndarray) -> ForwardResult:
    """The numpy arm's TCP positions as the references' start reads them (an anchor reads no orientation)."""
    n = p.shape[0]
    return ForwardResult(p, np.broadcast_to(np.eye(3), (n, 3, 3)), np.zeros((n, 0)))


def _reference_estimator(fit: ReferenceFit, groups: tuple[ReferenceRecords, ...]) -> np.ndarray:
    """scipy + numpy over the same unknowns (the fit's estimated parameters and the anchors), from the same
    start (the nominal robot and the anchors' closed-form spheres): the robot parameters it finds."""
    arm = VectorisedArm(DESC)
    est = np.array(fit.estimated)
    start = DESC.parameters.nominal.copy()
    scales = DESC.parameters.scales[est]
    anchors0 = [g.reference.started(_positions_only(arm.positions(g.joints, start)), g.values) for g in groups]
    u0 = np.concatenate([[s.nominal for s in a.unknowns] for a in anchors0])

    def residuals(x: np.ndarray) -> np.ndarray:
        theta = start.copy()
        theta[est] += scales * x[: est.size]
        u, out, k = x[est.size :] + u0, [], 0
        for group, anchor in zip(groups, anchors0, strict=True):
            size = len(anchor.unknowns)
            a = u[k : k + 3]
            delta = u[k + 3] if size == 4 else 0.0
            k += size
            p = arm.positions(group.joints, theta)
            out.append((np.linalg.norm(p - a, axis=1) - group.values - delta) / SIGMA_MM)
        return np.concatenate(out)

    found = scipy.optimize.least_squares(residuals, np.zeros(est.size + u0.size), method="trf", xtol=1e-12)
    theta = start.copy()
    theta[est] += scales * found.x[: est.size]
    return theta


def run() -> dict[str, object]:
    fresh = sample_workspace(DESC, 300, seed=999)
    errors, times, tracker_times = SeedErrors(), [], []
    for seed in SEEDS:
        truth, groups = _campaign(seed)
        identify_references(DESC, groups, noise=NOISE)  # warm: the solver for this many unknowns
        started = time.perf_counter()
        fit = identify_references(DESC, groups, noise=NOISE)
        times.append(time.perf_counter() - started)
        errors.add(seed, fit, **aligned_errors(DESC, fit, truth, fresh, _reference_estimator(fit, groups)))
        # The same number of position records from a tracker, through the tracker pipeline.
        robot, joints = perturbed_robot(DESC, seed=seed), sample_workspace(DESC, 3 * PER_ANCHOR, seed=seed)
        position_only = measure(robot, joints, NOISE, seed, position_only=True)
        identify(DESC, position_only, noise=NOISE)
        started = time.perf_counter()
        identify(DESC, position_only, noise=NOISE)
        tracker_times.append(time.perf_counter() - started)
    pivots = [Anchor(f"a{k + 1}", (float(a[0]), float(a[1]), float(a[2]))) for k, a in enumerate(ANCHORS)]
    candidates = tuple(
        ReferenceRecords(pivot, sample_workspace(DESC, 150, seed=500 + k), np.zeros(150))
        for k, pivot in enumerate(pivots)
    )
    started = time.perf_counter()
    design = design_reference_records(DESC, candidates, 30, "I", noise=NOISE, seed=1)
    design_s = time.perf_counter() - started
    designed = design.metrics["predicted_rms_tcp_mm"] / design.random_baseline["predicted_rms_tcp_mm"]
    time_ratio = statistics.median(times) / statistics.median(tracker_times)
    return {
        **errors.summary(),
        "identify_references_s": statistics.median(times),
        "tracker_identify_s": statistics.median(tracker_times),
        "design_30_of_450": {
            "predicted_rms_tcp_um": 1e3 * design.metrics["predicted_rms_tcp_mm"],
            "random_median_um": 1e3 * design.random_baseline["predicted_rms_tcp_mm"],
            "seconds": design_s,
        },
        "targets": [
            *aligned_fit_targets("ballbar", errors.medians(), (1.3, 0.2, 1.05), len(SEEDS)),
            target("ballbar identification time / a tracker campaign's of as many records", time_ratio, 3.0),
            target("30 designed ballbar records: predicted TCP error / random sets of 30", designed, 0.8),
        ],
    }
