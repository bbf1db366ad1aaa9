"""An adaptive campaign (optimal_design.adaptive) run against a simulated robot with a known truth, and fixed
designs' campaigns on the same pool: what the tests and the benchmark compare.

The "actual" error is the RMS over held-out workspace poses of the TCP position of the estimate against the
truth's (both in the instrument's frame): what the predicted RMS TCP error (√tr(L M⁻¹)) forecasts. The
prediction "at the truth" is that of the same records linearised at the true parameters: what the plant's
campaign really delivers in expectation, which neither loop can compute (both stop on a prediction at an
estimate or the nominal).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models import RobotDescription, forward_kinematics, sample_workspace
from models._types import Array
from models.campaign import Campaign
from models.identification import identify
from models.simulation import SimulatedRobot, measure
from optimal_design import design_for_target, design_poses
from optimal_design.adaptive import AdaptiveSettings, Pool, Progress, Step, advance, predicted
from optimal_design.information import candidate_information

HELD_OUT = 300
HELD_OUT_SEED = 4242


@dataclass(frozen=True)
class Blunders:
    """Gross errors a plant sees (a beam break, the wrong reflector): each record with probability `rate` is off
    by a size uniform in [low_mm, high_mm] in a random direction, drawn from (seed, the record's number)."""

    rate: float = 0.05
    low_mm: float = 0.3
    high_mm: float = 2.0
    seed: int = 0

    def apply(self, records: Campaign, first: int) -> list[int]:
        """Corrupt `records` (numbered from `first`) in place; the numbers of those corrupted."""
        hit = []
        for k in range(records.size):
            rng = np.random.default_rng([self.seed, first + k])
            if rng.uniform() < self.rate:
                direction = rng.normal(size=3)
                size = rng.uniform(self.low_mm, self.high_mm)
                records.positions[k] += size * direction / np.linalg.norm(direction)
                hit.append(first + k)
        return hit


@dataclass(frozen=True)
class AdaptiveRun:
    records: int
    """Records measured until the campaign stopped (blunders included)."""
    predicted: dict[str, float]
    actual_rms_mm: float
    reason: str
    blunders: tuple[int, ...]
    """The records flagged as blunders."""
    steps: list[Step] = field(repr=False)
    at_truth_mm: float = float("nan")
    """The predicted target error of the records kept, linearised at the truth."""
    corrupted: tuple[int, ...] = ()
    """The records the simulation made blunders (`Blunders`)."""
    asked: Array = field(default_factory=lambda: np.empty((0, 0)), repr=False)
    """Every pose the campaign asked for (internal units), in order."""


def actual_rms(desc: RobotDescription, theta: Array, truth: SimulatedRobot) -> float:
    """RMS TCP position error of `theta` against the truth over held-out workspace poses (mm)."""
    held = sample_workspace(desc, HELD_OUT, seed=HELD_OUT_SEED)
    error = forward_kinematics(desc, held, theta).positions - forward_kinematics(desc, held, truth.truth).positions
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))


def predicted_at(desc: RobotDescription, joints: Array, theta: Array, settings: AdaptiveSettings) -> dict[str, float]:
    """The predicted errors (mm) of measuring `joints` once each, linearised at `theta`."""
    info = candidate_information(
        desc, joints, position_only=settings.kind.position_only, noise=settings.noise, params=theta
    )
    return predicted(info, info.information(np.ones(info.size)))


def _joined(a: Campaign, b: Campaign) -> Campaign:
    quats = None if a.quaternions is None or b.quaternions is None else np.vstack([a.quaternions, b.quaternions])
    return Campaign(np.vstack([a.joints, b.joints]), np.vstack([a.positions, b.positions]), quats)


def run_adaptive(
    desc: RobotDescription,
    truth: SimulatedRobot,
    settings: AdaptiveSettings,
    *,
    blunder_at: int | None = None,
    blunder_mm: float = 0.5,
    blunders: Blunders | None = None,
    seed: int = 0,
) -> AdaptiveRun:
    """Measure what the campaign asks until done: the record numbered `blunder_at` off by `blunder_mm` along x,
    and/or random `blunders`."""
    pool = Pool.build(desc, settings)
    position_only = settings.kind.position_only
    records = Campaign(np.empty((0, desc.n_joints)), np.empty((0, 3)), None if position_only else np.empty((0, 4)))
    step = advance(desc, pool, settings, Progress(records))
    asked, steps, corrupted, poses = tuple(step.next_pool), [step], list[int](), [step.next_joints]
    while not step.done:
        new = measure(
            truth, step.next_joints, settings.noise, seed=seed * 1000 + records.size, position_only=position_only
        )
        if blunder_at is not None and records.size <= blunder_at < records.size + new.size:
            new.positions[blunder_at - records.size, 0] += blunder_mm
        if blunders is not None:
            corrupted += blunders.apply(new, records.size)
        records = _joined(records, new)
        step = advance(desc, pool, settings, Progress(records, step.excluded, step.estimate, asked))
        asked += tuple(i for i in step.next_pool if i >= 0 and i not in asked)
        steps.append(step)
        poses.append(step.next_joints)
    assert step.estimate is not None and step.predicted is not None
    kept = [i for i in range(records.size) if i not in step.excluded]
    at_truth = predicted_at(desc, records.joints[kept], truth.truth, settings)[settings.target_key]
    return AdaptiveRun(
        records.size,
        step.predicted,
        actual_rms(desc, step.estimate, truth),
        step.reason or "",
        tuple(b.record for s in steps for b in s.blunders),
        steps,
        at_truth,
        tuple(corrupted),
        np.vstack(poses),
    )


@dataclass(frozen=True)
class FixedRun:
    count: int
    """The smallest count of the fixed design (D) whose predicted error reaches the target (optimal_design.target)."""
    predicted_mm: float
    actual_rms_mm: float
    """Of the estimate identified from that design's records."""


def run_fixed(desc: RobotDescription, truth: SimulatedRobot, settings: AdaptiveSettings, *, seed: int = 0) -> FixedRun:
    """The target mode's D design on the same candidates (count, seed, noise), measured and identified."""
    keyword = {settings.target_key: settings.target_mm}
    found = design_for_target(
        desc,
        criterion="D",
        measurement=settings.measurement,
        candidate_count=settings.candidate_count,
        seed=settings.seed,
        noise=settings.noise,
        **keyword,  # type: ignore[arg-type]
    )
    assert found.design is not None
    records = measure(truth, found.design.joints, settings.noise, seed=seed, position_only=settings.kind.position_only)
    result = identify(desc, records, noise=settings.noise, strict=True)
    predicted = float(found.design.metrics[f"predicted_{settings.target_key}"])
    return FixedRun(found.count, predicted, actual_rms(desc, result.parameters, truth))


@dataclass(frozen=True)
class FixedAtCount:
    """A fixed design of `count` poses planned before measuring (at `planned_at`: the nominal, or the truth for an
    oracle), measured on the truth and identified as a calibration is (robust, outliers excluded)."""

    count: int
    nominal_mm: float
    """Its predicted target error at the parameters it was planned at (what sized it)."""
    at_truth_mm: float
    """The records kept (outliers excluded), linearised at the truth."""
    actual_rms_mm: float
    excluded: int
    """Records the identification excluded as outliers."""


def fixed_at_count(
    desc: RobotDescription,
    truth: SimulatedRobot,
    settings: AdaptiveSettings,
    count: int,
    *,
    criterion: str = "I",
    planned_at: Array | None = None,
    blunders: Blunders | None = None,
    seed: int = 0,
) -> FixedAtCount:
    """Design `count` poses on the campaign's pool (at `planned_at`, None: the nominal), measure, identify."""
    design = design_poses(
        desc,
        count,
        criterion,
        settings.measurement,
        candidate_count=settings.candidate_count,
        seed=settings.seed,
        noise=settings.noise,
        params=planned_at,
    )
    records = measure(truth, design.joints, settings.noise, seed=seed, position_only=settings.kind.position_only)
    if blunders is not None:
        blunders.apply(records, 0)
    result = identify(desc, records, noise=settings.noise)
    out = {o.pose for o in result.outliers if o.excluded}
    kept = [i for i in range(count) if i not in out]
    at_truth = predicted_at(desc, design.joints[kept], truth.truth, settings)[settings.target_key]
    nominal = float(design.metrics[f"predicted_{settings.target_key}"])
    return FixedAtCount(count, nominal, at_truth, actual_rms(desc, result.parameters, truth), len(out))
