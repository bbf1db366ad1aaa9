"""Fleet priors (models.fleet, docs/fleet.md): how many poses a new unit needs with its fleet's population.

A simulated fleet of one model, the UR5-like arm with its probe (`models.simulation.fleet_unit`): every parameter
but the base is nominal + the model's systematic deviation (one tolerance, Gaussian, shared by every unit) +
the unit's own (`UNIT_SPREAD` of a tolerance); each unit's tracker is placed anew (3 m away, rotated 30°).

1. Ten units are calibrated from 200 random full poses each (a thorough commissioning calibration; σ 25 µm /
   0.01°, the defaults); their current versions give the population (`fleet_prior`), and each is compared with
   the others (leave-one-out: false flags).
2. Three new units: for each K of `COUNTS`, K poses designed (I criterion, 500 candidates) without the prior and
   with it (the design's information then holds the prior's), identified plainly and by MAP with the prior,
   over `SEEDS` noise draws each. The validation error is the true TCP position error of the calibrated model
   over 200 fresh poses (RMS, mm, without the measurement noise), the mean over the units and draws, as a
   validation with `register: true` sees it: after the best rigid motion, the geometry alone. The prior is of
   the robot's geometry; the base, the instrument's frame of that one campaign, has none and needs the data
   whatever the fleet knows (the same error in the calibration's own instrument frame is reported beside it:
   there the base's estimate, the same with and without the prior, soon dominates).
3. The target is the error the prior-free designs reach at `REFERENCE` poses; K_free and K_prior are the
   smallest K from which every larger K of the grid stays within it. Acceptance: K_prior ≤ 0.5 K_free. The same
   for the targets of `REFERENCES` is reported: below the prior's own level (what the population alone gives a
   unit, ~20 µm here) the data must do the work and the saving shrinks.
4. The target mode counts the same (`design_for_target`, predicted RMS TCP error of that target) with and
   without the prior.
"""

from __future__ import annotations

import time

import numpy as np

from benchmarks.timing import target
from models import RobotDescription, sample_workspace
from models._types import Array
from models.examples import ur5_like
from models.fleet import FleetPrior, UnitEstimate, fleet_prior, leave_one_out
from models.identification import IdentificationOptions, identify, registered_base, rigid_fit
from models.identification.prior import ParameterPrior
from models.kinematics import forward_kinematics
from models.simulation import SimulatedRobot, fleet_unit, measure
from optimal_design.design import design_poses
from optimal_design.target import design_for_target

UNITS = 10
UNIT_POSES = 200
UNIT_SPREAD = 0.01
"""Each unit's own deviation, in tolerances (the model's systematic one is 1): 5 µm on a 0.5 mm length."""
COUNTS = (5, 6, 7, 8, 10, 12, 15, 20, 25, 30, 40)
REFERENCE = 20
"""The prior-free design whose validation error is the target (the acceptance's); `REFERENCES` are reported."""
REFERENCES = (20, 25, 30, 40)
NEW_UNITS = (97, 98, 99)
SEEDS = 6
CANDIDATES = 500
VALIDATION = 200


def _fleet(desc: RobotDescription) -> tuple[FleetPrior, tuple[UnitEstimate, ...]]:
    units = []
    for k in range(UNITS):
        robot = fleet_unit(desc, k, spread=UNIT_SPREAD)
        result = identify(desc, measure(robot, sample_workspace(desc, UNIT_POSES, seed=100 + k), seed=200 + k))
        units.append(UnitEstimate(f"unit-{k}", result.parameters, result.std_errors, desc.parameters.nominal))
    return fleet_prior(desc.parameters, units), tuple(units)


def _errors(desc: RobotDescription, robot: SimulatedRobot, joints: np.ndarray, theta: np.ndarray) -> Array:
    """(geometry alone, in the instrument frame): RMS TCP position errors against the truth, mm."""
    truth = forward_kinematics(desc, joints, robot.truth).positions
    model = forward_kinematics(desc, joints, theta).positions
    aligned = registered_base(desc, theta, rigid_fit(model, truth))
    moved = forward_kinematics(desc, joints, aligned).positions
    return np.array([np.sqrt(np.mean(np.sum((m - truth) ** 2, axis=1))) for m in (moved, model)])


def _curve(desc: RobotDescription, prior: ParameterPrior | None) -> dict[int, Array]:
    """The mean validation errors (geometry alone, instrument frame) of K designed poses over the new units and
    the noise draws, per K."""
    candidates = sample_workspace(desc, CANDIDATES, seed=7)
    fresh = sample_workspace(desc, VALIDATION, seed=999)
    robots = [fleet_unit(desc, unit, spread=UNIT_SPREAD) for unit in NEW_UNITS]
    out = {}
    for count in COUNTS:
        design = design_poses(desc, count, "I", candidates=candidates, prior=prior)
        errors = []
        for u, robot in enumerate(robots):
            for seed in range(SEEDS):
                campaign = measure(robot, design.joints, seed=1000 * count + 100 * u + seed)
                result = identify(desc, campaign, options=IdentificationOptions(prior=prior))
                errors.append(_errors(desc, robot, fresh, result.parameters))
        out[count] = np.mean(errors, axis=0)
    return out


def _smallest(curve: dict[int, float], goal: float) -> int:
    """The smallest K from which every K of the grid reaches `goal` (the grid's last K + 1 if none)."""
    reached = COUNTS[-1] + 1
    for count in reversed(COUNTS):
        if curve[count] > goal:
            break
        reached = count
    return reached


def run() -> dict[str, object]:
    desc = ur5_like()
    started = time.perf_counter()
    population, units = _fleet(desc)
    fleet_seconds = time.perf_counter() - started
    flags = leave_one_out(desc.parameters, units)
    prior = population.prior()
    free = _curve(desc, None)
    with_prior = _curve(desc, prior)
    geometry = {k: float(v[0]) for k, v in free.items()}, {k: float(v[0]) for k, v in with_prior.items()}
    counts = {
        str(reference): {
            "goal_mm": round(geometry[0][reference], 5),
            "k_free": _smallest(geometry[0], geometry[0][reference]),
            "k_prior": _smallest(geometry[1], geometry[0][reference]),
        }
        for reference in REFERENCES
    }
    goal = geometry[0][REFERENCE]
    k_free, k_prior = _smallest(geometry[0], goal), _smallest(geometry[1], goal)
    candidates = sample_workspace(desc, CANDIDATES, seed=7)
    counted = {
        name: design_for_target(desc, rms_tcp_mm=goal, candidates=candidates, prior=p).count
        for name, p in (("free", None), ("prior", prior))
    }
    ratio = k_prior / k_free
    return {
        "units": UNITS,
        "unit_poses": UNIT_POSES,
        "unit_spread_tolerances": UNIT_SPREAD,
        "parameters_with_prior": len(population.covered),
        "fleet_seconds": round(fleet_seconds, 3),
        "false_outlier_flags": sum(c.outlier for c in flags),
        "validation_error_mm": {
            str(k): {
                "free": round(float(free[k][0]), 5),
                "prior": round(float(with_prior[k][0]), 5),
                "free_instrument_frame": round(float(free[k][1]), 5),
                "prior_instrument_frame": round(float(with_prior[k][1]), 5),
            }
            for k in COUNTS
        },
        "goal_mm": round(goal, 5),
        "k_free": k_free,
        "k_prior": k_prior,
        "by_reference": counts,
        "target_mode_count": counted,
        "targets": [
            target("poses with the fleet prior / without, same validation error", ratio, 0.5),
            target(
                "target mode: poses counted with the prior / without",
                counted["prior"] / max(counted["free"], 1),
                1.0,
            ),
            target("units flagged as outliers among 10 of one population", sum(c.outlier for c in flags), 0),
        ],
    }
