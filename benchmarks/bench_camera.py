"""A UR5-like arm calibrated from a calibrated camera (the `image` records): a camera 1.5 m away, fx ≈ 2000 px
with distortion, seeing four markers on the tool in 40 images, σ 0.1 px, every DH parameter of the truth
perturbed, the camera's pose unknown (found from no guess); eight seeds.

- accuracy: the calibrated model's TCP error on 300 fresh poses (the truth in the gauge the camera leaves free,
  so no alignment) against the Cramér–Rao bound of the same campaign (the covariance of the fit's unknowns at
  the stated σ, propagated to those poses), and against the nominal model's error (after the best rigid
  alignment: what the nominal model could at best be placed to);
- an independent reference estimator in the same run: scipy's `least_squares` ('trf', finite-difference
  Jacobian) on the same records with the kinematics in plain numpy (`benchmarks/numpy_arm.py`) and the
  projection written in numpy (`harness.camera.project`), over the same unknowns from the same start: the two
  must agree;
- design: 20 images chosen among the candidate images of 600 random poses (I criterion), their predicted TCP
  error against the median of random sets of 20 of the same candidates.
"""

from __future__ import annotations

import statistics
import time

import numpy as np
import scipy.optimize

from benchmarks.numpy_arm import VectorisedArm, _rodrigues
from benchmarks.timing import target
from harness.ballbar import SeedErrors, aligned_rms, predicted_rms
from harness.camera import INTRINSICS, MARKERS, project, world_camera_campaign
from models import NoiseModel, forward_kinematics, sample_workspace
from models.description.examples import ur5_like
from models.identification import identify
from models.identification.reference_fit import ReferenceFit, identify_references
from models.measurements.camera import Camera
from models.measurements.references import ReferenceRecords
from models.simulation import measure, perturbed_robot
from optimal_design.references import camera_candidates, design_reference_records

SIGMA_PX = 0.1
IMAGES = 40
SEEDS = (1, 2, 3, 4, 5, 6, 7, 8)
NOISE = NoiseModel(0.002, 1e-5)
DESC = ur5_like()


def _reference_estimator(fit: ReferenceFit, group: ReferenceRecords) -> np.ndarray:
    """scipy + numpy over the same unknowns (the fit's estimated robot parameters and the camera's position and
    rotation vector about its start), from the same start (the nominal robot and the camera's closed-form
    pose): the robot parameters it finds."""
    arm = VectorisedArm(DESC)
    est = np.array(fit.estimated)
    start = DESC.parameters.nominal.copy()
    scales = DESC.parameters.scales[est]
    camera = fit.references[0].reference
    assert isinstance(camera, Camera)
    r0, t0 = _rodrigues(np.asarray(camera.rotation)), np.asarray(camera.position)
    markers, pixels = group.values[:, 2:5], group.values[:, 5:7]

    def residuals(x: np.ndarray) -> np.ndarray:
        theta = start.copy()
        theta[est] += scales * x[: est.size]
        pose = arm.poses(group.joints, theta)
        world = np.einsum("nij,nj->ni", pose[:, :3, :3], markers) + pose[:, :3, 3]
        rotation = _rodrigues(1e-3 * x[est.size + 3 :]) @ r0
        cam = (world - (t0 + x[est.size : est.size + 3])) @ rotation
        return ((project(cam, INTRINSICS) - pixels) / SIGMA_PX).ravel()

    found = scipy.optimize.least_squares(residuals, np.zeros(est.size + 6), method="trf", xtol=1e-12)
    theta = start.copy()
    theta[est] += scales * found.x[: est.size]
    return theta


def _design() -> dict[str, float]:
    campaign = world_camera_campaign(DESC, 1, images=IMAGES, sigma_px=SIGMA_PX)
    fit = identify_references(DESC, campaign.groups, noise=NOISE)
    camera = fit.references[0].reference  # its pose as the fit found it: the design's start
    assert isinstance(camera, Camera)
    candidates = camera_candidates(DESC, camera, sample_workspace(DESC, 600, seed=42), MARKERS, sigma_px=SIGMA_PX)
    started = time.perf_counter()
    design = design_reference_records(DESC, (candidates,), 20, "I", noise=NOISE, seed=1)
    return {
        "candidates": float(len(np.unique(candidates.joints, axis=0))),
        "predicted_rms_tcp_um": 1e3 * design.metrics["predicted_rms_tcp_mm"],
        "random_median_um": 1e3 * design.random_baseline["predicted_rms_tcp_mm"],
        "seconds": time.perf_counter() - started,
    }


def run() -> dict[str, object]:
    fresh = sample_workspace(DESC, 300, seed=999)
    errors, times, tracker_times = SeedErrors(), [], []
    for seed in SEEDS:
        campaign = world_camera_campaign(DESC, seed, images=IMAGES, sigma_px=SIGMA_PX)
        identify_references(DESC, campaign.groups, noise=NOISE)  # warm: the solver for this many unknowns
        started = time.perf_counter()
        fit = identify_references(DESC, campaign.groups, noise=NOISE)
        times.append(time.perf_counter() - started)
        # As many full-pose tracker records, through the tracker pipeline, warm: the time baseline.
        tracked = measure(perturbed_robot(DESC, seed=seed), sample_workspace(DESC, IMAGES, seed=seed), NOISE, seed)
        identify(DESC, tracked, noise=NOISE)
        started = time.perf_counter()
        identify(DESC, tracked, noise=NOISE)
        tracker_times.append(time.perf_counter() - started)
        true_p = forward_kinematics(DESC, fresh, campaign.truth).positions

        def rms(theta: np.ndarray, true_p: np.ndarray = true_p) -> float:
            error = forward_kinematics(DESC, fresh, theta).positions - true_p
            return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))

        errors.add(
            seed,
            fit,
            tcp_after=rms(fit.parameters),
            bound=predicted_rms(DESC, fit, fresh, stated=True),
            nominal=aligned_rms(forward_kinematics(DESC, fresh).positions, true_p),
            reference_estimator=rms(_reference_estimator(fit, campaign.groups[0])),
        )
    design = _design()
    ratio, better, agree = errors.medians()
    designed = design["predicted_rms_tcp_um"] / design["random_median_um"]
    return {
        **errors.summary(),
        "identify_references_s": statistics.median(times),
        "tracker_identify_s": statistics.median(tracker_times),
        "design_20_images": design,
        "targets": [
            target("camera: TCP error / Cramér–Rao bound (median of 8 seeds)", ratio, 1.5),
            target("camera: TCP error / the nominal model's (aligned)", better, 0.25),
            target("camera: TCP error / scipy + numpy reference estimator's", agree, 1.05),
            target("camera: scipy + numpy reference estimator's TCP error / ours", 1 / agree, 1.05),
            target("20 designed images: predicted TCP error / random sets of 20", designed, 0.8),
            target(
                "camera identification time / a tracker campaign's of as many full-pose records",
                statistics.median(times) / statistics.median(tracker_times),
                3.0,
            ),
        ],
    }
