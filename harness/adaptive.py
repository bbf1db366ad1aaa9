"""An adaptive campaign (optimal_design.adaptive) run against a simulated robot with a known truth, and a fixed
design's campaign on the same pool: what the tests and the benchmark compare.

The "actual" error is the RMS over held-out workspace poses of the TCP position of the estimate against the
truth's (both in the instrument's frame): what the predicted RMS TCP error (√tr(L M⁻¹)) forecasts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from models import RobotDescription, forward_kinematics, sample_workspace
from models._types import Array
from models.campaign import Campaign
from models.identification import identify
from models.simulation import SimulatedRobot, measure
from optimal_design import design_for_target
from optimal_design.adaptive import AdaptiveSettings, Pool, Progress, Step, advance

HELD_OUT = 300
HELD_OUT_SEED = 4242


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


def actual_rms(desc: RobotDescription, theta: Array, truth: SimulatedRobot) -> float:
    """RMS TCP position error of `theta` against the truth over held-out workspace poses (mm)."""
    held = sample_workspace(desc, HELD_OUT, seed=HELD_OUT_SEED)
    error = forward_kinematics(desc, held, theta).positions - forward_kinematics(desc, held, truth.truth).positions
    return float(np.sqrt(np.mean(np.sum(error**2, axis=1))))


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
    seed: int = 0,
) -> AdaptiveRun:
    """Measure what the campaign asks (the record numbered `blunder_at` off by `blunder_mm` along x) until done."""
    pool = Pool.build(desc, settings)
    position_only = settings.kind.position_only
    records = Campaign(np.empty((0, desc.n_joints)), np.empty((0, 3)), None if position_only else np.empty((0, 4)))
    progress = Progress(records)
    step = advance(desc, pool, settings, progress)
    asked, steps = tuple(step.next_pool), [step]
    while not step.done:
        new = measure(
            truth, step.next_joints, settings.noise, seed=seed * 1000 + records.size, position_only=position_only
        )
        if blunder_at is not None and records.size <= blunder_at < records.size + new.size:
            new.positions[blunder_at - records.size, 0] += blunder_mm
        records = _joined(records, new)
        progress = Progress(records, step.excluded, step.estimate, asked)
        step = advance(desc, pool, settings, progress)
        asked += tuple(i for i in step.next_pool if i >= 0 and i not in asked)
        steps.append(step)
    assert step.estimate is not None and step.predicted is not None
    blunders = tuple(b.record for s in steps for b in s.blunders)
    return AdaptiveRun(
        records.size, step.predicted, actual_rms(desc, step.estimate, truth), step.reason or "", blunders, steps
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
