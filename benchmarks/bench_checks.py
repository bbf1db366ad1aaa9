"""The quick check (models.evaluation.checks, docs/checks.md): detection and false alarms on simulated truths.

Per seed, a fresh truth (`perturbed_robot`), calibrated from 60 random tracker positions (σ 25 µm), and a check
of 8 poses designed for that version (`optimal_design.checks.design_check`); then, with fresh noise:

- the robot as it is: flagged (not `fine`) in ≤ 5 % of checks (α = 0.01 stated);
- axis 3's joint offset moved by the angle that moves the TCP 0.1 mm RMS over the workspace: `changed` in
  ≥ 95 % of checks, how often the explanation is `link3.theta` itself, and how often a parameter of that link;
- the same change seen by 8 random poses instead of the designed ones (for comparison);
- the IWR with pose records: a 0.1 mm (prismatic) change of leg 3's offset, fewer seeds (its calibration is
  slower); a check's time, warm.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.timing import median_of, target
from harness.checks import Calibrated, calibrated, changed, tcp_equivalent
from models import RobotDescription, iwr, sample_workspace
from models.description.examples import ur5_like
from models.evaluation.checks import CheckResult, Verdict, check_version
from models.simulation import SimulatedRobot, measure
from optimal_design.checks import design_check

SEEDS = 200
IWR_SEEDS = 100
POSES = 8


def _rates(
    desc: RobotDescription, seeds: int, parameter: str, mm: float, *, position_only: bool, random_too: bool
) -> dict[str, float]:
    """Per seed: calibrate, design, check unchanged and changed; the fractions over the seeds."""
    index = desc.parameters.index[parameter]
    counts = dict.fromkeys(("false_alarm", "changed", "named", "named_within_its_link", "changed_random_poses"), 0)
    design_seconds = []
    for seed in range(seeds):
        version: Calibrated = calibrated(desc, 10_000 + 11 * seed, position_only=position_only)
        started = time.perf_counter()
        poses = design_check(
            desc, version.params, POSES, covariance=version.covariance, seed=seed, position_only=position_only
        ).joints
        design_seconds.append(time.perf_counter() - started)
        delta = tcp_equivalent(desc, version.params, index, mm) if parameter.endswith(".theta") else mm
        moved = changed(version.robot, index, delta)

        same = _check(desc, version, version.robot, poses, seed, position_only=position_only)
        after = _check(desc, version, moved, poses, seed + 1, position_only=position_only)
        counts["false_alarm"] += same.verdict is not Verdict.FINE
        counts["changed"] += after.verdict is Verdict.CHANGED
        name = "" if after.explanation is None else after.explanation.name
        counts["named"] += name == parameter
        counts["named_within_its_link"] += name.split(".", 1)[0] == parameter.split(".", 1)[0]
        if random_too:
            joints = sample_workspace(desc, POSES, seed=seed)
            random = _check(desc, version, moved, joints, seed + 2, position_only=position_only)
            counts["changed_random_poses"] += random.verdict is Verdict.CHANGED
    rates = {k: v / seeds for k, v in counts.items()}
    rates["design_seconds_median"] = float(np.median(design_seconds))
    return rates


def _check(
    desc: RobotDescription,
    version: Calibrated,
    robot: SimulatedRobot,
    joints: np.ndarray,
    seed: int,
    *,
    position_only: bool,
) -> CheckResult:
    records = measure(robot, joints, seed=seed, position_only=position_only)
    return check_version(desc, version.params, version.covariance, records)


def _check_seconds() -> float:
    desc = ur5_like()
    version = calibrated(desc, 1)
    records = measure(version.robot, sample_workspace(desc, POSES, seed=2), seed=3, position_only=True)
    check_version(desc, version.params, version.covariance, records)
    return median_of(lambda: check_version(desc, version.params, version.covariance, records), 50)


def run() -> dict[str, object]:
    ur5 = _rates(ur5_like(), SEEDS, "link3.theta", 0.1, position_only=True, random_too=True)
    leg = _rates(iwr(), IWR_SEEDS, "leg3.offset", 0.1, position_only=False, random_too=False)
    seconds = _check_seconds()
    return {
        "ur5_axis3_0.1mm_positions": ur5,
        "iwr_leg3_0.1mm_poses": leg,
        "seeds": {"ur5": SEEDS, "iwr": IWR_SEEDS},
        "check_seconds": seconds,
        "targets": [
            target("UR5 axis 3, 0.1 mm at the TCP: changed (designed 8 poses)", ur5["changed"], 0.95, ">="),
            target("UR5 unchanged: flagged (alpha 0.01)", ur5["false_alarm"], 0.05),
            target("IWR leg 3 offset 0.1 mm: changed (designed 8 poses)", leg["changed"], 0.95, ">="),
            target("IWR unchanged: flagged (alpha 0.01)", leg["false_alarm"], 0.05),
            target("check, warm (s)", seconds, 0.05),
        ],
    }
