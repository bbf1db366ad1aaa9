"""Which records to take against references (a ballbar's anchors, fixed points, planes): pose design on the
rows those records would add to the fit of `models.identification.reference_fit`.

A candidate is a joint vector against one of the references (its anchor position, point or plane taken as the
user describes it). Its block holds exactly the scaled rows the fit would stack: columns the robot parameters
that fit would estimate, then every reference's unknowns. The task matrix `L` has the robot's TCP sensitivity
in the robot columns and zeros in the references', so trace(L M⁻¹) is the predicted TCP variance with the
references' unknowns marginalised out: what their records leave of the robot's accuracy. Everything after the
blocks (the relaxation and its certificate, rounding, exchange, the random baseline) is the tracker's design.

A candidate is a stop of the robot: the records of one reference at the same joints are one candidate, their
rows stacked in its block. For a ballbar that is one record; for a camera it is an image, all the points it sees
at that pose (`camera_candidates` makes them: only the points in front of the camera and on its image), since a
camera cannot be made to take some of an image's points and not the others.

Records already measured (`fixed`) are evaluated with the candidates in one fit's rows (a reference measured so
far keeps its unknowns): their information is the problem's base, which the chosen records complete, and their
stops count in the minimum spread, as a tracker's fixed poses do.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TypedDict, Unpack

import numpy as np

from models import NoiseModel, RobotDescription
from models._types import Array
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime, runtime_for
from models.identification.options import IdentificationOptions
from models.identification.reference_fit import check_references, reference_problem
from models.kinematics import forward_kinematics
from models.measurements.camera import Camera
from models.measurements.references import ReferenceRecords
from optimal_design.constraints import Spread
from optimal_design.criteria import Criterion, DesignCriterion, criterion_of
from optimal_design.information import CandidateInformation, task_matrix, task_rows
from optimal_design.problem import DesignProblem
from optimal_design.report import PoseDesign
from optimal_design.solve import solve
from optimal_design.target import Target, TargetDesign, target_on


def reference_information(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel | None = None,
    params: Array | None = None,
    estimate: tuple[str, ...] = IdentificationOptions().estimate,
    runtime: Runtime | None = None,
) -> CandidateInformation:
    """The blocks of every candidate record (`candidates`: per reference, its candidate joints; their values are
    not used) over the unknowns the fit would estimate."""
    options: _Options = {"noise": noise, "params": params, "estimate": estimate, "runtime": runtime}
    return _weighed(desc, candidates, (), options).info


@dataclass(frozen=True)
class _Weighed:
    """The candidates' information, and what the records already measured (`fixed`) add to it: their rows'
    information (`base`) and their stops (one per reference and distinct joint vector, as a candidate is)."""

    info: CandidateInformation
    base: Array
    fixed_joints: Array


def _weighed(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    fixed: tuple[ReferenceRecords, ...],
    options: _Options,
) -> _Weighed:
    """One evaluation of the fit's rows over the candidates and the fixed records together: the unknowns are the
    fit's of both (a reference measured only so far has its unknowns too), the fixed rows' information the base
    the candidates complete."""
    rt, noise = runtime_for(desc, options.get("runtime")), options.get("noise") or NoiseModel()
    params = options.get("params")
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    groups, fixed_of = _with_fixed(candidates, fixed, noise)
    check_references(groups)
    estimate = options.get("estimate", IdentificationOptions().estimate)
    problem = reference_problem(desc, groups, noise=noise, theta=theta, estimate=estimate, runtime=rt)
    at_start = problem.evaluate(np.zeros(problem.n_free))
    if at_start is None:
        raise ValueError("the model is undefined at these candidates")  # sampled or checked joints: a bug
    fixed_rows, candidate_rows = _split_rows(groups, fixed_of, at_start.jacobian)
    joints, blocks = _stops(candidates, candidate_rows)
    free = tuple(int(i) for i in problem.free)
    n_robot, n_all = len(free), problem.n_free
    task = np.zeros((n_all, n_all))
    task[:n_robot, :n_robot] = task_matrix(desc, free, runtime=rt)
    robot_rows = task_rows(desc, free, runtime=rt)
    tcp_rows = np.zeros((*robot_rows.shape[:2], n_all))
    tcp_rows[:, :, :n_robot] = robot_rows
    info = CandidateInformation(
        joints=joints,
        blocks=blocks,
        free=free,
        task=task,
        position_only=True,
        task_rows=tcp_rows,
    )
    stops = [np.unique(g.joints, axis=0) for g in fixed]
    fixed_joints = np.vstack(stops) if stops else np.empty((0, desc.n_joints))
    return _Weighed(info, fixed_rows.T @ fixed_rows, fixed_joints)


def _with_fixed(
    candidates: tuple[ReferenceRecords, ...], fixed: tuple[ReferenceRecords, ...], noise: NoiseModel
) -> tuple[tuple[ReferenceRecords, ...], list[int]]:
    """The groups the fit would see (each reference's fixed records, then its candidates; the candidates'
    references in their order, then those only measured so far) and how many of each group's records are
    fixed."""
    by_name = {g.reference.name: g for g in fixed}
    if len(by_name) != len(fixed):
        raise ValueError("fixed records: one group per reference")  # the service groups them: a bug
    groups, fixed_of = [], []
    for group in candidates:
        done = by_name.pop(group.reference.name, None)
        groups.append(group if done is None else _stacked(done, group, noise))
        fixed_of.append(0 if done is None else done.size)
    for done in by_name.values():
        groups.append(done)
        fixed_of.append(done.size)
    return tuple(groups), fixed_of


def _stacked(done: ReferenceRecords, group: ReferenceRecords, noise: NoiseModel) -> ReferenceRecords:
    """One reference's fixed records then its candidates, as one group (a σ each where either states one)."""
    sigma = None
    if done.sigma_mm is not None or group.sigma_mm is not None:
        sigma = np.concatenate(
            [g.sigma_mm if g.sigma_mm is not None else np.full(g.size, noise.position_mm) for g in (done, group)]
        )
    return ReferenceRecords(
        group.reference,
        np.vstack([done.joints, group.joints]),
        np.concatenate([done.values, group.values]),
        sigma,
    )


def _split_rows(groups: tuple[ReferenceRecords, ...], fixed_of: list[int], jacobian: Array) -> tuple[Array, Array]:
    """(the fixed records' rows, the candidates' rows in their groups' order) of the fit's Jacobian."""
    fixed_rows, candidate_rows = [], []
    row = 0
    for group, done in zip(groups, fixed_of, strict=True):
        r = group.reference.traits.rows
        fixed_rows.append(jacobian[row : row + done * r])
        candidate_rows.append(jacobian[row + done * r : row + group.size * r])
        row += group.size * r
    return np.vstack(fixed_rows), np.vstack(candidate_rows)


def _stops(candidates: tuple[ReferenceRecords, ...], jacobian: Array) -> tuple[Array, Array]:
    """(joints (M, n_joints), blocks (M, rows, P)): one candidate per reference and distinct joint vector (in
    the order they first appear), its records' rows stacked; shorter blocks padded with zero rows, which weigh
    nothing."""
    stops: list[tuple[Array, Array]] = []
    row = 0
    for group in candidates:
        r = group.reference.traits.rows
        rows = jacobian[row : row + group.size * r].reshape(group.size, r, -1)
        row += group.size * r
        _, first, which = np.unique(group.joints, axis=0, return_index=True, return_inverse=True)
        for stop in np.argsort(first):
            mine = np.flatnonzero(which.reshape(-1) == stop)
            stops.append((group.joints[first[stop]], rows[mine].reshape(-1, rows.shape[2])))
    height = max(b.shape[0] for _, b in stops)
    blocks = np.zeros((len(stops), height, jacobian.shape[1]))
    for i, (_, block) in enumerate(stops):
        blocks[i, : block.shape[0]] = block
    return np.array([j for j, _ in stops]), blocks


def camera_candidates(
    desc: RobotDescription,
    camera: Camera,
    joints: Array,
    targets: Array,
    *,
    sigma_px: float = 0.1,
    params: Array | None = None,
    runtime: Runtime | None = None,
) -> ReferenceRecords:
    """The candidate images of `camera` (at its start pose) at each of `joints`: per pose, the `targets` (mm:
    markers in the tool frame for a camera in the cell, board points in the world for one on the tool) that are
    in front of it and on its image under the model `params` (nominal: None). A pose that sees none is no
    candidate. The pixels are the predicted ones (design reads none); `sigma_px` their expected noise."""
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    fk = forward_kinematics(desc, joints, theta, check_ranges=False, runtime=rt)
    n, m = fk.positions.shape[0], targets.shape[0]
    y = camera.in_parent(
        np.repeat(fk.positions, m, axis=0), np.repeat(fk.rotations, m, axis=0), np.tile(targets, (n, 1))
    )
    rotation, position = camera.orientation(np.zeros(3)), np.asarray(camera.position)
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels, _ = camera.intrinsics.project((y - position) @ rotation)
    seen = camera.intrinsics.inside(pixels)
    pose, point = np.divmod(np.arange(n * m), m)
    values = np.column_stack([pose, point, np.tile(targets, (n, 1)), pixels])[seen]
    return ReferenceRecords(camera, np.asarray(joints)[pose[seen]], values, np.full(int(seen.sum()), sigma_px))


class _Options(TypedDict, total=False):
    noise: NoiseModel | None
    params: Array | None
    estimate: tuple[str, ...]
    runtime: Runtime | None


class DesignedOptions(_Options, total=False):
    """The options of a design beside the candidates': the records already measured (`fixed`, per reference:
    their information joins the design's, which completes it) and the minimum spread between the chosen stops
    and from the fixed ones (`min_spread`, the metric of optimal_design.constraints)."""

    fixed: tuple[ReferenceRecords, ...]
    min_spread: float | None


@single_threaded_blas
def design_reference_records(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    count: int,
    criterion: str | Criterion | DesignCriterion = Criterion.I,
    *,
    seed: int = 0,
    d_efficiency_floor: float | None = None,
    bound_seconds: float = 0.0,
    **options: Unpack[DesignedOptions],
) -> PoseDesign:
    """Choose `count` of the candidates (their order: the candidates' groups one after the other, each group's
    distinct joint vectors in the order they first appear, so a chosen index says which reference it belongs to;
    a camera's candidate is an image). The I criterion (default) minimises the predicted TCP
    error directly. `d_efficiency_floor` and `bound_seconds` as `optimal_design.design_poses`' (branch and bound
    tightens the relaxation's bound on these blocks)."""
    started = time.perf_counter()
    problem = reference_design_problem(desc, candidates, **options)
    return solve(
        desc,
        problem,
        criterion_of(criterion),
        count,
        seed=seed,
        started=started,
        d_efficiency_floor=d_efficiency_floor,
        bound_seconds=bound_seconds,
    )


@single_threaded_blas
def reference_records_for_target(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    *,
    rms_tcp_mm: float | None = None,
    max_tcp_mm: float | None = None,
    criterion: str | Criterion | DesignCriterion = Criterion.I,
    seed: int = 0,
    **options: Unpack[DesignedOptions],
) -> TargetDesign:
    """How many of the candidate records reach a predicted TCP accuracy ("how many ballbar records for
    0.05 mm"): the smallest count whose design does, and the curve of the error against the count."""
    started = time.perf_counter()
    target = Target.of(rms_tcp_mm, max_tcp_mm, criterion)
    problem = reference_design_problem(desc, candidates, **options)
    kinds = sorted({g.reference.traits.kind for g in candidates})
    return target_on(desc, problem, target, seed=seed, measurement="+".join(kinds), started=started)


def reference_design_problem(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    *,
    fixed: tuple[ReferenceRecords, ...] = (),
    min_spread: float | None = None,
    **options: Unpack[_Options],
) -> DesignProblem:
    """The design problem of the candidate records: their blocks, the fixed records' information as its base
    (a fixed stop counts as a chosen one in `n_fixed`), and the spread over the candidates' and fixed stops'
    joints."""
    weighed = _weighed(desc, candidates, fixed, options)
    info, done = weighed.info, weighed.fixed_joints
    spread = Spread.of(desc, info.joints, done, float(min_spread)) if min_spread else None
    return DesignProblem(
        info=info,
        base=weighed.base,
        n_fixed=done.shape[0],
        rows=info.rows,
        position_only=True,
        origin=np.arange(info.size),
        excluded={},
        spread=spread,
        offered=info.size,
    )
