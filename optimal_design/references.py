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
"""

from __future__ import annotations

import time
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
    rt, noise = runtime_for(desc, runtime), noise or NoiseModel()
    check_references(candidates)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    problem = reference_problem(desc, candidates, noise=noise, theta=theta, estimate=estimate, runtime=rt)
    at_start = problem.evaluate(np.zeros(problem.n_free))
    if at_start is None:
        raise ValueError("the model is undefined at these candidates")  # sampled or checked joints: a bug
    joints, blocks = _stops(candidates, at_start.jacobian)
    free = tuple(int(i) for i in problem.free)
    n_robot, n_all = len(free), problem.n_free
    task = np.zeros((n_all, n_all))
    task[:n_robot, :n_robot] = task_matrix(desc, free, runtime=rt)
    robot_rows = task_rows(desc, free, runtime=rt)
    tcp_rows = np.zeros((*robot_rows.shape[:2], n_all))
    tcp_rows[:, :, :n_robot] = robot_rows
    return CandidateInformation(
        joints=joints,
        blocks=blocks,
        free=free,
        task=task,
        position_only=True,
        task_rows=tcp_rows,
    )


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


@single_threaded_blas
def design_reference_records(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    count: int,
    criterion: str | Criterion | DesignCriterion = Criterion.I,
    *,
    seed: int = 0,
    **options: Unpack[_Options],
) -> PoseDesign:
    """Choose `count` of the candidates (their order: the candidates' groups one after the other, each group's
    distinct joint vectors in the order they first appear, so a chosen index says which reference it belongs to;
    a camera's candidate is an image). The I criterion (default) minimises the predicted TCP
    error directly."""
    started = time.perf_counter()
    problem = _problem(desc, candidates, options)
    return solve(desc, problem, criterion_of(criterion), count, seed=seed, started=started)


@single_threaded_blas
def reference_records_for_target(
    desc: RobotDescription,
    candidates: tuple[ReferenceRecords, ...],
    *,
    rms_tcp_mm: float | None = None,
    max_tcp_mm: float | None = None,
    criterion: str | Criterion | DesignCriterion = Criterion.I,
    seed: int = 0,
    **options: Unpack[_Options],
) -> TargetDesign:
    """How many of the candidate records reach a predicted TCP accuracy ("how many ballbar records for
    0.05 mm"): the smallest count whose design does, and the curve of the error against the count."""
    started = time.perf_counter()
    target = Target.of(rms_tcp_mm, max_tcp_mm, criterion)
    problem = _problem(desc, candidates, options)
    kinds = sorted({g.reference.traits.kind for g in candidates})
    return target_on(desc, problem, target, seed=seed, measurement="+".join(kinds), started=started)


def _problem(desc: RobotDescription, candidates: tuple[ReferenceRecords, ...], options: _Options) -> DesignProblem:
    info = reference_information(desc, candidates, **options)
    return DesignProblem(
        info=info,
        base=np.zeros((info.n_params, info.n_params)),
        n_fixed=0,
        rows=info.rows,
        position_only=True,
        origin=np.arange(info.size),
        excluded={},
        spread=None,
        offered=info.size,
    )
