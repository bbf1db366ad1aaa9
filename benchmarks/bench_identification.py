"""Identification end to end: new and repeated campaign sizes, a fresh process, and the alternatives.

Every identification below is the full product call (`identify`: validation,
registration, identifiability, IPOPT, statistics, predicted accuracy) on a
simulated perturbed IWR. Baselines in the same run: scipy's least_squares
('trf' with a finite-difference Jacobian, 'lm' with the exact CasADi
Jacobian) on the same residuals, and the two one-graph-per-campaign CasADi
formulations (nested rootfinder, implicit with closure constraints).
"""

from __future__ import annotations

import subprocess
import sys
import time
from functools import partial

import numpy as np
import scipy.optimize

from benchmarks.identification_formulations import solve_implicit, solve_nested
from benchmarks.timing import median_of, target
from models import NoiseModel, default_registry, forward_kinematics, iwr, sample_workspace
from models.campaign import Campaign
from models.identification import identify
from models.identification.residuals import CampaignProblem
from models.simulation import SimulatedRobot, measure, perturbed_robot

SIZES = (30, 60, 100, 300, 1000)

_FRESH = """
import time
t = time.perf_counter()
from models import iwr, sample_workspace
from models.identification import identify
from models.simulation import measure, perturbed_robot
desc = iwr()
sim = perturbed_robot(desc, seed=1)
campaign = measure(sim, sample_workspace(desc, {n}, seed=5), seed=6)
t = time.perf_counter()
identify(desc, campaign)
print(time.perf_counter() - t)
"""


def _campaign(sim: SimulatedRobot, n: int, seed: int) -> Campaign:
    return measure(sim, sample_workspace(sim.desc, n, seed=seed), seed=seed + 1)


def _scipy(campaign: Campaign, method: str) -> tuple[float, float, np.ndarray]:
    """(seconds, objective per equation, parameters) for scipy's least_squares on the same problem."""
    desc = iwr()
    result = identify(desc, campaign)  # only for the start point and the subset, not timed
    free = np.array(result.estimated)
    problem = CampaignProblem(desc, default_registry().runtime(desc), campaign, NoiseModel(), result.start, free)
    started = time.perf_counter()
    if method == "trf":
        out = scipy.optimize.least_squares(problem.residual_vector, np.zeros(free.size), method="trf", xtol=1e-12)
    else:

        def jac(z: np.ndarray) -> np.ndarray:
            ev = problem.evaluate(z)
            assert ev is not None
            return ev.jacobian

        out = scipy.optimize.least_squares(
            problem.residual_vector, np.zeros(free.size), jac=jac, method="lm", xtol=1e-12
        )
    seconds = time.perf_counter() - started
    r = problem.residual_vector(out.x)
    return seconds, 0.5 * float(r @ r) / r.size, problem.theta(out.x)


def run() -> dict[str, object]:
    desc = iwr()
    _ = default_registry().runtime(desc).kinematics
    sim = perturbed_robot(desc, seed=1)
    identify(desc, _campaign(sim, 45, 999))  # the service warms up like this at start-up
    out: dict[str, object] = {}
    targets = []
    for n in SIZES:
        campaign = _campaign(sim, n, n)
        started = time.perf_counter()
        first = identify(desc, campaign)
        new_n = time.perf_counter() - started
        warm = median_of(partial(identify, desc, campaign), 3)
        out[f"n{n}"] = {
            "new_n_s": new_n,
            "warm_s": warm,
            "ipopt_iterations": first.solver.iterations,
            "ipopt_s": first.solver.seconds,
            "status": first.status,
        }
    fresh = {}
    for n in (60, 1000):
        runs = [
            float(
                subprocess.run(
                    [sys.executable, "-c", _FRESH.format(n=n)], capture_output=True, text=True, check=True
                ).stdout
            )
            for _ in range(2)
        ]
        fresh[f"n{n}"] = min(runs)
    out["fresh_process_first_call_s"] = fresh
    n60, n1000 = out["n60"], out["n1000"]
    assert isinstance(n60, dict) and isinstance(n1000, dict)
    targets += [
        target("60 poses, never-seen N (s)", n60["new_n_s"], 0.5),
        target("60 poses, warm (s)", n60["warm_s"], 0.2),
        target("1000 poses, never-seen N (s)", n1000["new_n_s"], 5.0),
        target("60 poses, first call of a fresh process (s)", fresh["n60"], 0.5),
    ]

    # Baselines on one campaign of 60 poses.
    campaign = _campaign(sim, 60, 60)
    repeats = [identify(desc, campaign) for _ in range(3)]
    ours = repeats[0]
    ours_s = min(r.seconds for r in repeats)
    ours_solve_s = min(r.solver.seconds for r in repeats)
    ours_obj = ours.solver.objective
    check = sample_workspace(desc, 100, seed=77)
    ours_tcp = forward_kinematics(desc, check, ours.parameters).positions
    baselines: dict[str, object] = {"ours_end_to_end_s": ours_s, "ours_ipopt_solve_s": ours_solve_s}
    for method in ("trf", "lm"):
        seconds, objective, theta = min((_scipy(campaign, method) for _ in range(2)), key=lambda r: r[0])
        tcp = forward_kinematics(desc, check, theta).positions
        baselines[method] = {
            "seconds": seconds,
            "ratio": seconds / ours_solve_s,
            "ratio_vs_our_end_to_end": seconds / ours_s,
            "objective_rel_diff": abs(objective - ours_obj) / ours_obj,
            "max_tcp_diff_mm": float(np.abs(tcp - ours_tcp).max()),
        }
    trf = baselines["trf"]
    assert isinstance(trf, dict)
    targets.append(
        target("speed-up vs scipy trf + finite differences, 60 poses, solve vs solve", trf["ratio"], 20.0, ">=")
    )
    for n in (30, 60):
        c = _campaign(sim, n, n)
        res = identify(desc, c)
        free = np.array(res.estimated)
        baselines[f"nested_rootfinder_n{n}"] = solve_nested(desc, c, res.start, free, NoiseModel())
        baselines[f"implicit_closure_n{n}"] = solve_implicit(desc, c, res.start, free, NoiseModel())
        baselines[f"ours_n{n}_s"] = res.seconds
        baselines[f"ours_n{n}_objective"] = res.solver.objective
    out["baselines"] = baselines
    out["targets"] = targets
    return out
