"""Drift-aware campaigns (issue 32): a tracker frame that creeps 30 µm over a 60-record campaign, removed.

A simulated IWR with thesis-sized errors, a tracker of σ 10 µm / 0.002°, 60 records with the reference pose every
6th and the other poses in a sweep along the carriage, the tracker's frame moving 30 µm along a random direction
linearly from the first record to the last. Per seed: the TCP error on 100 fresh poses of the calibration with
the drift removed, of the one that ignores it, and of the same records measured without drift (the baseline),
and how far the fitted drift is from the simulated one in its own σ. Timed: `identify_with_drift` against
`identify` on the same records (fastest of 5, taking turns).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial

import numpy as np

from benchmarks.timing import target
from harness.drift import drift_campaign, tcp_error_mm
from models import NoiseModel, iwr, sample_workspace
from models.identification import identify
from models.identification.drift import identify_with_drift

NOISE = NoiseModel(0.010, float(np.radians(0.002)))
SEEDS = range(10)
REPEATS = 5


def run() -> dict[str, object]:
    desc = iwr()
    fresh = sample_workspace(desc, 100, seed=99)
    removed, kept, z, rounds, scatter = [], [], [], [], []
    for seed in SEEDS:
        sim = drift_campaign(desc, seed, noise=NOISE)
        free = identify(desc, sim.clean, noise=NOISE)
        raw = identify(desc, sim.drifted, noise=NOISE)
        fit = identify_with_drift(desc, sim.drifted, sim.timeline, noise=NOISE)
        baseline = tcp_error_mm(desc, sim.robot, free.parameters, fresh)
        removed.append(tcp_error_mm(desc, sim.robot, fit.result.parameters, fresh) / baseline)
        kept.append(tcp_error_mm(desc, sim.robot, raw.parameters, fresh) / baseline)
        truth = sim.drift_mm[-1] - sim.drift_mm[0]
        z.extend(((fit.drift.total_mm - truth) / fit.drift.total_sigma_mm).tolist())
        rounds.append(fit.drift.rounds)
        scatter.append((fit.drift.reference_scatter_before_mm, fit.drift.reference_scatter_after_mm))
    sim = drift_campaign(desc, 0, noise=NOISE)
    calls: list[Callable[[], object]] = [
        partial(identify, desc, sim.drifted, noise=NOISE),
        partial(identify_with_drift, desc, sim.drifted, sim.timeline, noise=NOISE),
    ]
    for call in calls:
        call()
    best = [float("inf")] * 2
    for _ in range(REPEATS):
        for k, call in enumerate(calls):
            started = time.perf_counter()
            call()
            best[k] = min(best[k], time.perf_counter() - started)
    med_removed, med_kept = float(np.median(removed)), float(np.median(kept))
    rms_z = float(np.sqrt(np.mean(np.square(z))))
    return {
        "seeds": len(SEEDS),
        "tcp_error_ratio_removed": removed,
        "tcp_error_ratio_ignored": kept,
        "median_removed": med_removed,
        "median_ignored": med_kept,
        "drift_error_rms_sigma": rms_z,
        "rounds": rounds,
        "reference_scatter_mm": scatter,
        "identify_s": best[0],
        "identify_with_drift_s": best[1],
        "time_ratio": best[1] / best[0],
        "targets": [
            target("TCP error, drift removed / drift-free campaign (median)", med_removed, 1.2),
            target("TCP error, drift ignored / drift-free campaign (median): the drift matters", med_kept, 1.2, ">="),
            target("fitted drift over the campaign off the simulated one, RMS in its σ", rms_z, 1.5),
            target("identification time, with the drift fit / without (same records)", best[1] / best[0], 3.5),
        ],
    }
