"""Which poses to measure: relaxation with a certificate, rounding, exchange, and the baselines."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from models import NoiseModel, RobotDescription, forward_kinematics, sample_workspace
from models.blas import single_threaded_blas
from models.errors import InvalidInput, TooFewMeasurements
from models.identifiability import measurement_rows
from models.kinematics import Array, as_joint_array, check_joint_ranges
from optimal_design.criteria import Criterion, metrics, utility, value
from optimal_design.exchange import exchange, greedy, round_weights
from optimal_design.information import CandidateInformation, candidate_information
from optimal_design.relaxation import Relaxation, relax

RANDOM_DRAWS = 20
MAX_CANDIDATES = 100_000


@dataclass(frozen=True)
class PoseDesign:
    criterion: Criterion
    position_only: bool
    joints: Array
    """(K, n_joints) chosen poses, internal units."""
    indices: tuple[int, ...]
    """Into the candidates (given or sampled)."""
    value: float
    """The exact criterion of the chosen poses (criteria.value)."""
    metrics: dict[str, float]
    random_baseline: dict[str, float]
    greedy: dict[str, Any]
    bound: dict[str, Any] | None
    efficiency: float | None
    relaxation: dict[str, Any]
    identifiable: tuple[str, ...]
    candidates: int
    fixed: int
    seconds: float
    notes: tuple[str, ...] = field(default=())

    def to_dict(self, desc: RobotDescription, include_indices: bool = True) -> dict[str, Any]:
        """Boundary units (mm, deg); the keys of api.md's pose-design response and more."""
        out: dict[str, Any] = {
            "criterion": self.criterion.value,
            "measurement": "position" if self.position_only else "pose",
            "count": len(self.indices),
            "poses": (self.joints * desc.joint_to_boundary).tolist(),
            "value": _finite(self.value),
            "metrics": {k: _finite(v) for k, v in self.metrics.items()},
            "random_baseline": {k: _finite(v) for k, v in self.random_baseline.items()},
            "greedy": self.greedy,
            "bound": self.bound,
            "efficiency": _finite(self.efficiency),
            "relaxation": self.relaxation,
            "identifiable": list(self.identifiable),
            "candidates": self.candidates,
            "fixed": self.fixed,
            "seconds": self.seconds,
            "notes": list(self.notes),
        }
        if include_indices:
            out["indices"] = list(self.indices)
        return out


def _finite(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def efficiency(criterion: Criterion, design_utility: float, bound: float, n_params: int) -> float:
    """Design against the bound, 1 = as good as the relaxation (D: per-parameter geometric mean)."""
    if criterion is Criterion.D:
        return float(math.exp((design_utility - bound) / n_params))
    if criterion is Criterion.E:
        return float(design_utility / bound)
    return float(bound / design_utility)  # both negative: −trace, −cond


@single_threaded_blas
def design_poses(
    desc: RobotDescription,
    count: int,
    criterion: str | Criterion = Criterion.D,
    measurement: str = "pose",
    *,
    candidates: ArrayLike | None = None,
    candidate_count: int = 2000,
    seed: int = 0,
    fixed: ArrayLike | None = None,
    noise: NoiseModel | None = None,
    params: ArrayLike | None = None,
) -> PoseDesign:
    """Choose `count` poses among candidates (given, or `candidate_count` sampled in the workspace)."""
    started = time.perf_counter()
    crit = criterion if isinstance(criterion, Criterion) else Criterion.parse(criterion)
    if measurement not in ("pose", "position"):
        raise InvalidInput(
            f"measurement must be 'pose' or 'position', got {measurement!r}",
            field="measurement",
            value=str(measurement),
            allowed=["pose", "position"],
        )
    position_only = measurement == "position"
    theta = None if params is None else desc.parameters.vector(params)
    if candidates is not None:
        cand = as_joint_array(desc, candidates)
        if cand.shape[0] == 0:
            raise InvalidInput(
                "candidates is empty: give at least `count` joint vectors, or omit them", field="candidates"
            )
        check_joint_ranges(desc, cand)
        forward_kinematics(desc, cand, theta)  # UnreachablePose names the first candidate outside the workspace
    else:
        if not 1 <= candidate_count <= MAX_CANDIDATES:
            raise InvalidInput(f"candidate_count must be between 1 and {MAX_CANDIDATES}, got {candidate_count}")
        cand = sample_workspace(desc, candidate_count, seed=seed, params=theta)
    n_fixed = 0
    if fixed is not None:
        done = as_joint_array(desc, fixed)
        check_joint_ranges(desc, done)
        n_fixed = done.shape[0]
        joints = np.vstack([done, cand])
    else:
        joints = cand
    if count < 1 or count > cand.shape[0]:
        raise InvalidInput(
            f"count must be between 1 and the number of candidates ({cand.shape[0]}), got {count}",
            field="count",
            value=count,
            min=1,
            max=int(cand.shape[0]),
        )
    info_all = candidate_information(desc, joints, position_only=position_only, noise=noise, params=theta)
    base = info_all.subset_information(np.arange(n_fixed)) if n_fixed else np.zeros((info_all.n_params,) * 2)
    info = CandidateInformation(
        joints=info_all.joints[n_fixed:],
        blocks=info_all.blocks[n_fixed:],
        free=info_all.free,
        task=info_all.task,
        position_only=position_only,
    )
    rows = measurement_rows(position_only)
    base_rank = int(np.linalg.matrix_rank(base)) if n_fixed else 0
    minimum = math.ceil((info.n_params - base_rank) / rows)
    if count < minimum:
        raise TooFewMeasurements(
            f"{count} {'position-only' if position_only else 'full-pose'} measurements cannot identify the "
            f"{info.n_params} identifiable parameters: choose at least {minimum}",
            got=count,
            needed=minimum,
            missing=minimum - count,
            kind="position" if position_only else "pose",
        )
    allowed = np.ones(info.size, dtype=bool)
    notes: list[str] = []
    timings: dict[str, float] = {"information_s": time.perf_counter() - started}

    t0 = time.perf_counter()
    relaxed: Relaxation | None
    try:
        relaxed = relax(info, crit, count, base)
    except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
        relaxed = None
        notes.append(f"the relaxation failed ({exc}); the design is the greedy one, improved by exchange")
    timings["relaxation_s"] = time.perf_counter() - t0
    if relaxed is not None and relaxed.note:
        notes.append(relaxed.note)

    t0 = time.perf_counter()
    g_design, g_swaps = exchange(info, crit, greedy(info, count, base, allowed), base=base, allowed=allowed)
    g_seconds = time.perf_counter() - t0
    g_utility = utility(crit, base + info.subset_information(g_design), info.task)

    t0 = time.perf_counter()
    if relaxed is not None:
        r_design, r_swaps = exchange(
            info,
            crit,
            round_weights(relaxed.weights, count, allowed),
            base=base,
            allowed=allowed,
            weights=relaxed.weights,
        )
        r_utility = utility(crit, base + info.subset_information(r_design), info.task)
    else:
        r_design, r_swaps, r_utility = g_design, g_swaps, g_utility
    timings["rounding_exchange_s"] = time.perf_counter() - t0
    chosen, chosen_utility = r_design, r_utility
    if g_utility > r_utility:
        chosen, chosen_utility = g_design, g_utility
        notes.append("the greedy start ended better than the rounded relaxation after exchange: it is the answer")

    m = base + info.subset_information(chosen)
    bound_info: dict[str, Any] | None = None
    eff: float | None = None
    if relaxed is not None and relaxed.bound is not None:
        eff = efficiency(crit, chosen_utility, relaxed.bound, info.n_params)
        bound_info = {
            "criterion": crit.value,
            "value": _finite(_natural(crit, relaxed.bound)),
            "utility": relaxed.bound,
            "certified": True,
            "method": relaxed.method,
            "solver_status": relaxed.status,
        }
    rng = np.random.default_rng(seed + 1)
    draws = [
        metrics(
            base + info.subset_information(rng.choice(info.size, count, replace=False)),
            rows * (count + n_fixed),
            info.task,
        )
        for _ in range(RANDOM_DRAWS)
    ]
    baseline = {k: float(np.median([d[k] for d in draws])) for k in draws[0]}
    names = desc.parameters.names
    return PoseDesign(
        criterion=crit,
        position_only=position_only,
        joints=info.joints[chosen],
        indices=tuple(int(i) for i in chosen),
        value=value(crit, m, info.task),
        metrics=metrics(m, rows * (count + n_fixed), info.task),
        random_baseline=baseline,
        greedy={
            "value": _finite(value(crit, base + info.subset_information(g_design), info.task)),
            "efficiency": _finite(efficiency(crit, g_utility, relaxed.bound, info.n_params))
            if relaxed is not None and relaxed.bound is not None
            else None,
            "swaps": g_swaps,
            "seconds": g_seconds,
        },
        bound=bound_info,
        efficiency=eff,
        relaxation={
            "method": relaxed.method if relaxed else None,
            "status": relaxed.status if relaxed else "failed",
            "iterations": relaxed.iterations if relaxed else 0,
            "seconds": relaxed.seconds if relaxed else 0.0,
            "exchange_swaps": r_swaps,
            **timings,
        },
        identifiable=tuple(names[i] for i in info.free),
        candidates=info.size,
        fixed=n_fixed,
        seconds=time.perf_counter() - started,
        notes=tuple(notes),
    )


def _natural(criterion: Criterion, u: float) -> float:
    if criterion in (Criterion.D, Criterion.E):
        return u
    if criterion is Criterion.I:
        return math.sqrt(-u) if u < 0 else 0.0
    return -u
