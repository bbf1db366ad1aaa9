"""Which records to take of a tree of chains (`models.tree`): a tool's pose or position at a joint vector of the
whole tree, or one tool in another's frame (the torch on the positioner's part, one hand seen from the other).

Each candidate record gives the rows `identify_tree` would stack for it: the tool's (or the relative pose's)
exact Jacobian wrt the tree's GLOBAL parameters (`models.tree.kinematics`), rows divided by the record's σ and
columns multiplied by the parameters' tolerances, on the subset the candidates identify (QR with column
pivoting over the whole pool, `analyse_identifiability`, as the fit picks its own). Position records have 3
rows, pose records 6; a pool that mixes them pads the position ones with zero rows, which add no information
and leave every rank-one and low-rank update of the search well posed. From there the problem is the chain's:
`DesignProblem` and its search (`optimal_design.solve.search`: relaxation with its certificate, greedy and
rounded starts, exchange), every criterion of `optimal_design.criteria` included.

The I criterion's task matrix is the tree's: the mean over random joint vectors of the whole tree (one seed)
of every tool's position rows and of each `relative` pair's, so trace(L M⁻¹) is the mean predicted position
variance of the tools and relative poses the user cares about (mm²). The design reports that accuracy per
tool and per relative pair, from the covariance M⁻¹ the chosen records predict (`predicted_accuracy`), and
the same numbers for random selections of the same size from the same pool (the baseline).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Registry, default_registry
from models.errors import InvalidInput
from models.identifiability import analyse_identifiability
from models.measurement import MeasurementKind
from models.noise import NoiseModel
from models.tree import RobotTree, ToolAccuracy, predicted_accuracy, tree_joint_samples, tree_joints
from models.tree.accuracy import ACCURACY_SEED
from models.tree.kinematics import relative_poses, tool_poses
from optimal_design.criteria import Criterion, DesignCriterion, criterion_of, metrics
from optimal_design.information import CandidateInformation, max_tcp_error
from optimal_design.problem import DesignProblem
from optimal_design.solve import search

TASK_SAMPLES = 200
"""Random joint vectors of the tree behind the I criterion's task matrix and the reported accuracies."""
RANDOM_DRAWS = 20


@dataclass(frozen=True)
class TreeCandidate:
    """One record a campaign could take: tool `tool` at the tree's global `joints`, in the instrument's frame or
    in tool `frame`'s, its position alone or its whole pose."""

    tool: str
    joints: Array
    """(n_joints,) the tree's global joints, mm and rad."""
    frame: str | None = None
    position_only: bool = True
    sigma_mm: float | None = None
    """This record's position σ (a camera on a hand is not a tracker); None: the noise model's."""

    @property
    def label(self) -> str:
        return self.tool if self.frame is None else f"{self.tool}/{self.frame}"

    @property
    def rows(self) -> int:
        return 3 if self.position_only else 6


def tree_candidates(
    tree: RobotTree,
    joints: ArrayLike,
    *,
    tools: Sequence[str] | None = None,
    relative: Sequence[tuple[str, str]] = (),
    measurement: str = "position",
    sigma_mm: float | None = None,
) -> tuple[TreeCandidate, ...]:
    """Every record the joint vectors offer: at each, one per tool of `tools` (default: every tip) and one per
    (tool, frame) pair of `relative`, all of the `measurement` kind ("position" or "pose")."""
    q = tree_joints(tree, joints)
    position_only = MeasurementKind.parse(measurement).position_only
    names = list(tree.tips) if tools is None else [tree.tip(t, f"tools[{k}]").name for k, t in enumerate(tools)]
    pairs = [
        (tree.tip(a, f"relative[{k}]").name, tree.tip(b, f"relative[{k}]").name) for k, (a, b) in enumerate(relative)
    ]
    out: list[TreeCandidate] = []
    for row in q:
        out += [TreeCandidate(t, row, None, position_only, sigma_mm) for t in names]
        out += [TreeCandidate(a, row, b, position_only, sigma_mm) for a, b in pairs]
    return tuple(out)


@dataclass(frozen=True)
class TreeDesign:
    """The chosen records, their criterion, and the accuracy they predict against random selections."""

    criterion: Criterion
    chosen: tuple[TreeCandidate, ...]
    indices: tuple[int, ...]
    """Into the candidates given."""
    value: float
    """The criterion of the chosen records (criteria.value: log det for D, mm for I …)."""
    efficiency: float | None
    """Against the relaxation's certified bound (1: as good as any selection can be)."""
    metrics: dict[str, float]
    """The chain's design metrics (log det, condition number, O1–O5; `predicted_rms_tcp_mm` is the RMS over
    the tools and relative pairs of the task)."""
    random_baseline: dict[str, float]
    """The median of the same metrics over RANDOM_DRAWS random selections of as many candidates, plus
    `value`, the criterion's."""
    accuracy: tuple[ToolAccuracy, ...]
    """Predicted 1-σ error of each tool, then of each relative pair, after identification from the chosen
    records (first order, at the nominal parameters)."""
    random_accuracy: tuple[ToolAccuracy, ...]
    """The same for the median random selection (by the criterion)."""
    identifiable: tuple[str, ...]
    candidates: int
    fixed: int
    seconds: float
    notes: tuple[str, ...] = field(default=())

    def groups(self) -> list[tuple[str, str | None, bool, Array]]:
        """The chosen records as a campaign takes them: (tool, frame, position only, (n, n_joints) joints) per
        kind of record, in the order first chosen (each one group of `ToolRecords` for `identify_tree`)."""
        found: dict[tuple[str, str | None, bool], list[Array]] = {}
        for c in self.chosen:
            found.setdefault((c.tool, c.frame, c.position_only), []).append(c.joints)
        return [(tool, frame, only, np.array(rows)) for (tool, frame, only), rows in found.items()]


@dataclass(frozen=True)
class TreeInformation:
    """The candidates' (and the fixed records') information on the subset they identify, and the task."""

    info: CandidateInformation
    base: Array
    """(P, P) the fixed records' information."""
    free: tuple[int, ...]


def tree_information(
    tree: RobotTree,
    candidates: Sequence[TreeCandidate],
    *,
    fixed: Sequence[TreeCandidate] = (),
    relative: Sequence[tuple[str, str]] = (),
    noise: NoiseModel | None = None,
    params: ArrayLike | None = None,
    registry: Registry | None = None,
) -> TreeInformation:
    """Every candidate's scaled rows (see the module docstring), the fixed records' information, and the task."""
    noise, registry = noise or NoiseModel(), registry or default_registry()
    theta = tree.parameters.nominal if params is None else tree.parameters.vector(params)
    every = [*fixed, *candidates]
    _check(tree, candidates, fixed)
    rows = max(c.rows for c in every)
    scaled = np.zeros((len(every), rows, tree.n_params))
    by_kind: dict[tuple[str, str | None], list[int]] = {}
    for i, c in enumerate(every):
        by_kind.setdefault((c.tool, c.frame), []).append(i)
    scales = tree.parameters.scales
    for (tool, frame), index in by_kind.items():
        q = np.array([every[i].joints for i in index])
        poses = (
            tool_poses(tree, tool, q, theta, jacobian=True, check_ranges=False, registry=registry)
            if frame is None
            else relative_poses(tree, tool, frame, q, theta, jacobian=True, check_ranges=False, registry=registry)
        )
        assert poses.jacobians is not None
        for k, i in enumerate(index):
            c = every[i]
            sigma = noise.position_mm if c.sigma_mm is None else c.sigma_mm
            weights = np.array([1.0 / sigma] * 3 + [1.0 / noise.orientation_rad] * 3)[: c.rows]
            scaled[i, : c.rows] = poses.jacobians[k, : c.rows] * weights[:, None] * scales[None, :]
    ident = analyse_identifiability(scaled.reshape(-1, tree.n_params), tree.parameters)
    free = ident.identifiable
    blocks = np.ascontiguousarray(scaled[:, :, list(free)])
    n_fixed = len(fixed)
    flat = blocks[:n_fixed].reshape(-1, len(free))
    task_rows = _task_rows(tree, theta, free, relative, registry)
    info = CandidateInformation(
        joints=np.array([c.joints for c in candidates]),
        blocks=blocks[n_fixed:],
        free=free,
        task=np.asarray(task_rows.reshape(-1, len(free)).T @ task_rows.reshape(-1, len(free)) / task_rows.shape[0]),
        position_only=all(c.position_only for c in every),
        task_rows=task_rows,
    )
    return TreeInformation(info, np.asarray(flat.T @ flat, dtype=float), free)


def _check(tree: RobotTree, candidates: Sequence[TreeCandidate], fixed: Sequence[TreeCandidate]) -> None:
    """Each record's tool, frame, joints and σ, the first bad one named by its place."""
    if not candidates:
        raise InvalidInput("give at least one candidate record", field="candidates")
    for where, records in (("candidates", candidates), ("fixed", fixed)):
        for k, c in enumerate(records):
            tree.check_record(c.tool, c.frame, f"{where}[{k}]")
            if c.sigma_mm is not None and not c.sigma_mm > 0:
                raise InvalidInput(f"{where}[{k}].sigma_mm must be a positive number of mm", field=f"{where}[{k}]")
        if records:
            tree_joints(tree, np.array([np.asarray(c.joints, dtype=float) for c in records]))


def _task_rows(
    tree: RobotTree, theta: Array, free: tuple[int, ...], relative: Sequence[tuple[str, str]], registry: Registry
) -> Array:
    """(T·N, 3, P) scaled position rows of every tool and relative pair at TASK_SAMPLES random joint vectors."""
    q = tree_joint_samples(tree, TASK_SAMPLES, ACCURACY_SEED)
    scales = tree.parameters.scales[list(free)]
    rows = []
    for tip in tree.tips:
        jac = tool_poses(tree, tip, q, theta, jacobian=True, check_ranges=False, registry=registry).jacobians
        assert jac is not None
        rows.append(jac[:, :3][:, :, list(free)] * scales)
    for tool, frame in relative:
        jac = relative_poses(
            tree, tool, frame, q, theta, jacobian=True, check_ranges=False, registry=registry
        ).jacobians
        assert jac is not None
        rows.append(jac[:, :3][:, :, list(free)] * scales)
    return np.concatenate(rows)


@single_threaded_blas
def design_tree(
    tree: RobotTree,
    candidates: Sequence[TreeCandidate],
    count: int,
    criterion: str | Criterion | DesignCriterion = Criterion.D,
    *,
    fixed: Sequence[TreeCandidate] = (),
    relative: Sequence[tuple[str, str]] = (),
    noise: NoiseModel | None = None,
    params: ArrayLike | None = None,
    seed: int = 0,
    bound_seconds: float = 0.0,
    registry: Registry | None = None,
) -> TreeDesign:
    """Choose `count` of `candidates` (records of the tree's tools, `tree_candidates`) for `criterion`, with the
    `fixed` records already taken; `relative` pairs join the tools in the I criterion's task and in the report."""
    started = time.perf_counter()
    crit = criterion_of(criterion)
    registry = registry or default_registry()
    theta = tree.parameters.nominal if params is None else tree.parameters.vector(params)
    built = tree_information(
        tree, candidates, fixed=fixed, relative=relative, noise=noise, params=theta, registry=registry
    )
    info = built.info
    problem = _problem(built, len(fixed))
    found = search(problem, crit, count, started=started, bound_seconds=bound_seconds)
    m = built.base + info.subset_information(found.chosen)
    dof = sum(candidates[int(i)].rows for i in found.chosen) + sum(c.rows for c in fixed)
    report = _metrics(m, dof, info)
    baseline, median_draw = _random(
        problem, crit=crit, count=count, seed=seed, rows=[c.rows for c in candidates], fixed=fixed
    )
    bound = found.relaxed.bound if found.relaxed is not None else None

    def accuracy(chosen: NDArray[Any]) -> tuple[ToolAccuracy, ...]:
        return _accuracy(tree, theta, built, chosen, relative=relative, registry=registry)

    return TreeDesign(
        criterion=crit.name,
        chosen=tuple(candidates[int(i)] for i in found.chosen),
        indices=tuple(int(i) for i in found.chosen),
        value=crit.value(m, info.task),
        efficiency=None if bound is None else crit.efficiency(found.utility, bound, info.n_params),
        metrics=report,
        random_baseline=baseline,
        accuracy=accuracy(found.chosen),
        random_accuracy=accuracy(median_draw),
        identifiable=tuple(tree.parameters.names[i] for i in built.free),
        candidates=info.size,
        fixed=len(fixed),
        seconds=time.perf_counter() - started,
        notes=found.notes,
    )


def _problem(built: TreeInformation, n_fixed: int) -> DesignProblem:
    """The chain's problem on the tree's information: every candidate admissible (no filter, no spread)."""
    info = built.info
    return DesignProblem(
        info=info,
        base=built.base,
        n_fixed=n_fixed,
        rows=info.rows,
        position_only=info.position_only,
        origin=np.arange(info.size),
        excluded={},
        spread=None,
        offered=info.size,
    )


def _metrics(m: Array, dof: int, info: CandidateInformation) -> dict[str, float]:
    out = metrics(m, dof, info.task)
    assert info.task_rows is not None
    out["predicted_max_tcp_mm"] = max_tcp_error(info.task_rows, m)
    return out


def _random(
    problem: DesignProblem,
    *,
    crit: DesignCriterion,
    count: int,
    seed: int,
    rows: list[int],
    fixed: Sequence[TreeCandidate],
) -> tuple[dict[str, float], NDArray[Any]]:
    """(median metrics and criterion value over RANDOM_DRAWS random selections, the median draw by utility)."""
    info, base = problem.info, problem.base
    rng = np.random.default_rng([seed, 47])
    draws, picks, utilities = [], [], []
    for _ in range(RANDOM_DRAWS):
        pick = rng.choice(info.size, count, replace=False)
        m = base + info.subset_information(pick)
        d = _metrics(m, sum(rows[int(i)] for i in pick) + sum(c.rows for c in fixed), info)
        d["value"] = crit.value(m, info.task)
        draws.append(d)
        picks.append(pick)
        utilities.append(crit.utility(m, info.task))
    order = np.argsort(utilities)
    finite = {k: [d[k] for d in draws] for k in draws[0]}
    return {k: float(np.median(v)) for k, v in finite.items()}, picks[int(order[len(order) // 2])]


def _accuracy(
    tree: RobotTree,
    theta: Array,
    built: TreeInformation,
    chosen: NDArray[Any],
    *,
    relative: Sequence[tuple[str, str]],
    registry: Registry,
) -> tuple[ToolAccuracy, ...]:
    """Each tool's and pair's predicted accuracy from the covariance S M⁻¹ S the selection predicts."""
    m = built.base + built.info.subset_information(chosen)
    ev = np.linalg.eigvalsh(m)
    if ev[0] <= ev[-1] * 1e-14:
        inf = math.inf
        labels = [*tree.tips, *(f"{a}/{b}" for a, b in relative)]
        return tuple(ToolAccuracy(label, inf, inf, inf) for label in labels)
    scales = tree.parameters.scales[list(built.free)]
    cov = np.linalg.inv(m) * np.outer(scales, scales)
    return predicted_accuracy(tree, theta, built.free, cov, relative=relative, samples=TASK_SAMPLES, registry=registry)
