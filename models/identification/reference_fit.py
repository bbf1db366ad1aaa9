"""Identification from records against references (ballbar anchors, fixed points, planes): the robot's
parameters and every reference's unknowns in one weighted least-squares problem, solved by IPOPT through the
same solver pool as a tracker campaign, with its covariance and χ² check.

What these data cannot see is said, not guessed. No reference fixes a frame (`Reference.fixes_frame`): moving
the robot's base moves every anchor, point and plane with it, so the base transform is held at its start value
and reported unidentifiable, and the references are identified in the frame that base defines. Of the rest,
the references' own unknowns are kept first (a reference the data do not determine is refused, naming it), and
the robot's parameters are chosen from what those leave (QR with column pivoting on the columns projected off
the references'), so a redundancy is resolved against the robot's parameter, never a reference's.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.parameters import ParameterTable
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput, NonFiniteValue, TooFewMeasurements
from models.identifiability import analyse_identifiability
from models.identification.options import IdentificationOptions
from models.identification.polish import polish
from models.identification.registration import registered_base, rigid_fit
from models.identification.residuals import EvaluatedOnce, Evaluation
from models.identification.result import ReferenceEstimate
from models.identification.solver import SolverRun, solver_pool
from models.identification.statistics import Covariance, covariance, outlier_threshold
from models.kinematics import ForwardJacobianResult, as_joint_array, check_joint_ranges, forward_kinematics
from models.measurements.references import ReferenceRecords
from models.noise import NoiseModel

FRAME_GROUPS = ("base",)
"""The parameters a frame-free campaign cannot determine: the robot's base transform."""
MAX_EXCLUDED_SHARE = 0.2
"""Blunders are a few records: when more fail the test, the model or the stated noise misfits the campaign as a
whole, and they are named without being dropped (as for a tracker campaign)."""


@dataclass
class ReferenceProblem(EvaluatedOnce):
    """The weighted least squares of reference records. Unknowns z: the free robot parameters, then every
    reference's unknowns, each in units of its scale (θ[free] = θ₀[free] + scale · z)."""

    desc: RobotDescription
    runtime: Runtime
    groups: tuple[ReferenceRecords, ...]
    noise: NoiseModel
    theta_start: Array
    free: NDArray[np.intp]
    u_start: Array
    u_scales: Array
    _last: tuple[bytes, Evaluation | None] | None = field(default=None, repr=False)
    evaluations: int = 0
    polish_steps: int = 0
    """Gauss–Newton steps taken after IPOPT on this problem (`_solved`)."""

    def __post_init__(self) -> None:
        self.joints = np.vstack([g.joints for g in self.groups])
        self.records = np.cumsum([0, *(g.size for g in self.groups)])
        self.blocks = np.cumsum([0, *(len(g.reference.unknowns) for g in self.groups)])
        self.scales = self.desc.parameters.scales[self.free]
        self.weights = [
            1.0 / (np.full(g.size, self.noise.position_mm) if g.sigma_mm is None else np.asarray(g.sigma_mm))
            for g in self.groups
        ]

    @property
    def n_free(self) -> int:
        return int(self.free.size + self.u_start.size)

    def split(self, z: Array) -> tuple[Array, Array]:
        theta = self.theta_start.copy()
        theta[self.free] += self.scales * z[: self.free.size]
        return theta, self.u_start + self.u_scales * z[self.free.size :]

    def _evaluate(self, z: Array) -> Evaluation | None:
        self.evaluations += 1
        theta, u = self.split(z)
        fk = forward_kinematics(self.desc, self.joints, theta, jacobian=True, check_ranges=False, runtime=self.runtime)
        residuals, jacobians, raw = [], [], []
        n_robot = self.free.size
        for k, group in enumerate(self.groups):
            records = slice(self.records[k], self.records[k + 1])
            block = slice(self.blocks[k], self.blocks[k + 1])
            tcp = ForwardJacobianResult(
                fk.positions[records], fk.rotations[records], fk.platforms[records], fk.jacobians[records]
            )
            r, d_theta, d_u = group.reference.residuals(tcp, u[block], group.values)
            w = self.weights[k][:, None]
            rows = r.shape[0] * r.shape[1]
            j = np.zeros((rows, self.n_free))
            j[:, :n_robot] = (d_theta[:, :, self.free] * self.scales * w[:, :, None]).reshape(rows, n_robot)
            j[:, n_robot + block.start : n_robot + block.stop] = (d_u * self.u_scales[block] * w[:, :, None]).reshape(
                rows, -1
            )
            residuals.append((r * w).reshape(-1))
            jacobians.append(j)
            raw.append(d_theta.reshape(rows, -1))
        flat, jac = np.concatenate(residuals), np.vstack(jacobians)
        if not (np.all(np.isfinite(flat)) and np.all(np.isfinite(jac))):
            return None
        per = 1.0 / flat.size  # per equation, as the tracker's problem: IPOPT's tolerance means the same
        return Evaluation(
            theta=theta,
            platforms=fk.platforms,
            residuals=flat[:, None],
            jacobian=jac,
            raw_jacobian=np.vstack(raw)[:, None, :],
            objective=0.5 * per * float(flat @ flat),
            gradient=per * (jac.T @ flat),
            hessian=per * (jac.T @ jac),
        )


@dataclass(frozen=True)
class ReferenceOutlier:
    """A record whose residual fails the χ² test: its reference (by name and by place among the groups), its
    index among that reference's records as given, its statistic (Σr² in σ units) and the test's threshold."""

    reference: str
    group: int
    record: int
    statistic: float
    threshold: float
    excluded: bool


@dataclass(frozen=True)
class ReferenceFit:
    """The robot's parameters and the references' unknowns from one campaign of reference records."""

    table: ParameterTable
    parameters: Array
    """The robot's, at the solution (internal units)."""
    start: Array
    """What the fit started from (the nominal values, or a given version's; with tracker records, registered)."""
    estimated: tuple[int, ...]
    """The robot parameters estimated (table indices)."""
    std_errors: Array
    """Per robot parameter; NaN for those held (not estimated)."""
    unidentifiable: tuple[str, ...]
    """Robot parameters these data cannot determine, held at their start values."""
    frame: str
    """What the parameters and the references are expressed in."""
    references: tuple[ReferenceEstimate, ...]
    parameter_covariance: Array
    """A-posteriori covariance of the estimated robot parameters (`estimated` order), internal units."""
    covariance: Covariance
    """Of every unknown, in scale units, with the variance factor and its χ² interval."""
    solver: SolverRun
    outliers: tuple[ReferenceOutlier, ...]
    """Records no clean one would show, worst first; left out of the fit where `excluded`."""
    seconds: float
    groups: tuple[ReferenceRecords, ...] = ()
    """Every record as given, each group with its reference's closed-form start (what `references` started
    from): the records the per-record errors before and after the fit are reported on."""
    rechecked: bool = False
    """The records determine the same robot parameters at the solution as at the start (the linearisation the
    choice was made on held)."""
    evaluations: int = 0
    polish_steps: int = 0


def identify_references(
    desc: RobotDescription,
    groups: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel | None = None,
    nominal: Array | None = None,
    options: IdentificationOptions | None = None,
    runtime: Runtime | None = None,
) -> ReferenceFit:
    """Identify `desc`'s parameters (those of `options.estimate` these data determine) and every reference's
    unknowns from `groups` (internal units); see the module docstring for what is held and why."""
    started = time.perf_counter()
    rt, noise, options = runtime_for(desc, runtime), noise or NoiseModel(), options or IdentificationOptions()
    check_references(groups)
    groups = tuple(_validated(desc, g) for g in _numbered(groups))
    table = desc.parameters
    theta = _registered(desc, table.nominal if nominal is None else table.vector(nominal), groups, rt)
    groups = tuple(_started(desc, theta, g, rt) for g in groups)
    problem, z, final, run, outliers = _fit_without_blunders(
        desc, groups, noise=noise, theta=theta, options=options, rt=rt
    )
    held = sorted(set(table.indices(options.estimate)) - {int(i) for i in problem.free})
    fit = _result(problem, z, final, run, held=held, started=started, outliers=outliers)
    theta_fit, u_fit = problem.split(z)
    at_solution = replace(problem, theta_start=theta_fit, u_start=u_fit, _last=None, evaluations=0, polish_steps=0)
    # The chosen parameters still determined at the solution (the linearisation held); that the solution's
    # geometry would make more of them numerically visible is no news (`reference_problem`).
    again = _identifiable(at_solution, tuple(int(i) for i in problem.free))
    return replace(
        fit,
        groups=groups,
        rechecked=len(again) == problem.free.size,
        evaluations=problem.evaluations,
        polish_steps=problem.polish_steps,
        seconds=time.perf_counter() - started,
    )


def _fit_without_blunders(
    desc: RobotDescription,
    groups: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel,
    theta: Array,
    options: IdentificationOptions,
    rt: Runtime,
) -> tuple[ReferenceProblem, Array, Evaluation, SolverRun, tuple[ReferenceOutlier, ...]]:
    """The fit, refitted without its worst failing record while a few fail the outlier test (least squares
    smears a blunder over the others, so one at a time); with more than a few, every record back in and the
    failing ones named, none dropped: the model or the stated noise misfits the campaign as a whole (as for a
    tracker campaign)."""

    # What the records determine is analysed once, on them all (as the tracker's pipeline keeps its starting
    # subset): a refit without a blunder estimates the same parameters.
    given = groups
    first = reference_problem(desc, given, noise=noise, theta=theta, estimate=options.estimate, runtime=rt)

    def fitted(records: tuple[ReferenceRecords, ...]) -> tuple[ReferenceProblem, Array, Evaluation, SolverRun]:
        problem = (
            first if records is given else replace(first, groups=records, _last=None, evaluations=0, polish_steps=0)
        )
        return (problem, *_solved(problem, options))

    kept = [np.arange(g.size) for g in groups]
    outliers: list[ReferenceOutlier] = []
    total = sum(g.size for g in groups)
    while True:
        problem, z, final, run = fitted(groups)
        failing = _failing(problem, final, options.outlier_alpha, total)
        if not failing:
            return problem, z, final, run, tuple(outliers)
        k, i = failing[0].group, failing[0].record
        # Excluding must leave every reference determined: a plate's touches that fail one by one are a wrong
        # plate (or another plate's), not blunders.
        too_many = len(outliers) + 1 > MAX_EXCLUDED_SHARE * total
        if not options.exclude_outliers or too_many or groups[k].size <= groups[k].reference.minimum_records:
            if groups is not given:
                problem, z, final, run = fitted(given)
            named = tuple(replace(o, excluded=False) for o in _failing(problem, final, options.outlier_alpha, total))
            return problem, z, final, run, named
        outliers.append(replace(failing[0], record=int(kept[k][i])))
        keep = np.delete(np.arange(groups[k].size), i)
        kept[k] = kept[k][keep]
        groups = (*groups[:k], groups[k].subset(keep), *groups[k + 1 :])
        check_references(groups)


def _solved(problem: ReferenceProblem, options: IdentificationOptions) -> tuple[Array, Evaluation, SolverRun]:
    lower, upper = np.full(problem.n_free, -np.inf), np.full(problem.n_free, np.inf)
    run = solver_pool(problem.runtime).solve(problem, np.zeros(problem.n_free), lower, upper, options.max_iterations)
    z, problem.polish_steps = polish(problem, run.z, lower, upper)
    final = problem.evaluate(z)
    if final is None:
        raise InvalidInput("the model is undefined at the fitted parameters: these records do not fit this robot")
    return z, final, run


def _failing(problem: ReferenceProblem, final: Evaluation, alpha: float, total: int) -> list[ReferenceOutlier]:
    """The records whose Σr² (σ units) no clean record would show (a Bonferroni χ² test over the `total`
    records, as the tracker's), worst first (by statistic over threshold); indices within the groups as fitted."""
    residuals = final.residuals[:, 0]
    row, found = 0, []
    for k, group in enumerate(problem.groups):
        rows = group.reference.traits.rows
        statistic = np.sum(residuals[row : row + group.size * rows].reshape(group.size, rows) ** 2, axis=1)
        row += group.size * rows
        threshold = outlier_threshold(total, rows, alpha)
        for i in np.flatnonzero(statistic > threshold):
            found.append(ReferenceOutlier(group.reference.name, k, int(i), float(statistic[i]), threshold, True))
    return sorted(found, key=lambda o: -o.statistic / o.threshold)


def reference_problem(
    desc: RobotDescription,
    groups: tuple[ReferenceRecords, ...],
    *,
    noise: NoiseModel,
    theta: Array,
    estimate: tuple[str, ...],
    runtime: Runtime,
) -> ReferenceProblem:
    """The problem over the robot parameters of `estimate` these records determine (the frame held where no
    reference fixes one) and every reference's unknowns, at the references' current starts: what the fit
    solves, and what pose design weighs candidates by."""
    u_start = np.concatenate([[s.nominal for s in g.reference.unknowns] for g in groups])
    u_scales = np.concatenate([[s.scale for s in g.reference.unknowns] for g in groups])
    candidates = _candidates(desc, groups, estimate)
    none = np.arange(0, dtype=np.intp)
    # Which parameters these records determine is decided on the nominal geometry at their poses (the base where
    # the start has it), as the tracker's pipeline decides on the structure: a calibrated start has its parallel
    # axes a few hundredths of a degree apart, which makes their offsets along the axes numerically
    # "identifiable" from 2 µm data — and fitted to metres (measured: link2.d −1880 mm, link3.d 9391 mm from a
    # camera campaign re-fitted from its own calibration).
    structure = desc.parameters.nominal.copy()
    structure[desc.slices["base"]] = theta[desc.slices["base"]]
    at_structure = ReferenceProblem(desc, runtime, groups, noise, structure, none, u_start, u_scales)
    free = _identifiable(at_structure, candidates)
    return ReferenceProblem(desc, runtime, groups, noise, theta, np.asarray(free, dtype=np.intp), u_start, u_scales)


def _candidates(
    desc: RobotDescription, groups: tuple[ReferenceRecords, ...], estimate: tuple[str, ...]
) -> tuple[int, ...]:
    """The robot parameters of `estimate` that may be estimated at all: not the base where no group fixes a
    frame (module docstring)."""
    table = desc.parameters
    frame_free = not any(g.reference.traits.fixes_frame for g in groups)
    frame = set(table.indices(FRAME_GROUPS)) if frame_free else set()
    return tuple(i for i in table.indices(estimate) if i not in frame)


def check_references(groups: tuple[ReferenceRecords, ...]) -> None:
    """Records that can determine their references, and a length among them; a 4xx naming the fix otherwise."""
    if not groups:
        raise InvalidInput("no reference records: give at least one anchor, point or plane", field="measurements")
    names = [g.reference.name for g in groups]
    if len(set(names)) != len(names):
        raise InvalidInput(f"reference names repeat: {names}; give each anchor, point and plane once")
    for group in groups:
        group.check()
    if not any(g.reference.traits.fixes_scale for g in groups):
        raise InvalidInput(
            "fixed points and planes fix no length: the robot and its points and planes scaled together fit them "
            "as well (down to a robot of zero size); add the records of a ballbar or a distance sensor (an anchor) "
            "or tracker records",
            field="measurements",
            reason="no_length_scale",
        )


def _result(
    problem: ReferenceProblem,
    z: Array,
    final: Evaluation,
    run: SolverRun,
    *,
    held: list[int],
    started: float,
    outliers: tuple[ReferenceOutlier, ...],
) -> ReferenceFit:
    """The fit at its solution: the parameters and references with their standard errors and covariance."""
    table, u_scales = problem.desc.parameters, problem.u_scales
    frame_free = not any(g.reference.traits.fixes_frame for g in problem.groups)
    cov = covariance(final.jacobian, final.residuals)
    scales = np.concatenate([problem.scales, u_scales])
    std = np.sqrt(np.diag(cov.z)) * scales
    theta_fit, u_fit = problem.split(z)
    robot_std = np.full(len(table), np.nan)
    robot_std[problem.free] = std[: problem.free.size]
    return ReferenceFit(
        table=table,
        parameters=theta_fit,
        start=problem.theta_start,
        estimated=tuple(int(i) for i in problem.free),
        std_errors=robot_std,
        unidentifiable=tuple(table.names[i] for i in held),
        frame=(
            "the robot's base held at its start values (distance, point and plane records and a camera in the "
            "cell fix no frame): the parameters and the references are expressed in that base's frame"
            if frame_free
            else _fixed_frame(problem.groups)
        ),
        references=_estimates(problem, final, u_fit, std[problem.free.size :]),
        parameter_covariance=(cov.z * np.outer(scales, scales))[: problem.free.size, : problem.free.size],
        covariance=cov,
        solver=run,
        outliers=outliers,
        seconds=time.perf_counter() - started,
    )


def _fixed_frame(groups: tuple[ReferenceRecords, ...]) -> str:
    """What the frame is when records fix one: a tracker's, or the world a tool camera's board is given in."""
    fixing = ", ".join(
        f"{g.reference.traits.kind} {g.reference.name!r}" for g in groups if g.reference.traits.fixes_frame
    )
    return f"the frame of the records of {fixing} (the tracker's, or a board's: the robot's base, identified)"


def _identifiable(problem: ReferenceProblem, candidates: tuple[int, ...]) -> list[int]:
    """The robot parameters to estimate beside every reference's unknowns (see the module docstring)."""
    groups = problem.groups
    everything = ReferenceProblem(
        problem.desc,
        problem.runtime,
        groups,
        problem.noise,
        problem.theta_start,
        np.arange(len(problem.desc.parameters)),
        problem.u_start,
        problem.u_scales,
    )
    start = everything.evaluate(np.zeros(everything.n_free))
    if start is None:
        raise InvalidInput("the model is undefined at the start values: these records do not fit this robot")
    n_robot = len(problem.desc.parameters)
    robot, refs = start.jacobian[:, :n_robot], start.jacobian[:, n_robot:]
    if refs.shape[1] == 0:
        return list(analyse_identifiability(robot, problem.desc.parameters, candidates).identifiable)
    q, r, _ = np.linalg.svd(refs, full_matrices=False)
    strong = r > r[0] * 1e-9
    if not strong.all():
        weak = int(np.argmin(strong))
        block = int(np.searchsorted(everything.blocks, weak, side="right") - 1)
        ref = groups[block].reference
        raise TooFewMeasurements(
            f"the records of {ref.traits.kind} {ref.name!r} do not determine it (for a plane: touches spread over an "
            "area, not along a line; for an anchor: records around it in all directions)",
            got=groups[block].size,
            needed=ref.minimum_records,
            missing=0,
            kind=ref.traits.kind,
        )
    if not any(g.reference.traits.fixes_frame for g in groups):
        # The gauge is exact only where the records are consistent: moving the robot and every reference
        # rigidly changes no record there, but at a start whose socket records miss their point by millimetres
        # a turn about the first axis is only nearly invisible (measured: σ 1.3 against 2 700, link1.theta
        # "identifiable" and IPOPT out of iterations on it). The base's columns are those rigid motions: they
        # are projected off with the references' own, so what they span is never taken for information.
        gauge = robot[:, problem.desc.slices["base"]]
        q, r, _ = np.linalg.svd(np.hstack([refs, gauge]), full_matrices=False)
        q = q[:, r > r[0] * 1e-9]
    projected = robot - q @ (q.T @ robot)
    return list(analyse_identifiability(projected, problem.desc.parameters, candidates).identifiable)


def _numbered(groups: tuple[ReferenceRecords, ...]) -> tuple[ReferenceRecords, ...]:
    """Every record's place in the campaign: groups given without one (`index` None) are numbered on, in
    their order, after the places already given."""
    given = [g.index for g in groups if g.index is not None]
    at = int(max(int(i.max()) for i in given if i.size) + 1) if any(i.size for i in given) else 0
    numbered = []
    for g in groups:
        if g.index is None:
            numbered.append(replace(g, index=np.arange(at, at + g.size, dtype=np.intp)))
            at += g.size
        else:
            numbered.append(g)
    return tuple(numbered)


def _validated(desc: RobotDescription, group: ReferenceRecords) -> ReferenceRecords:
    """The records' joints in range and every number finite, σ positive: a 4xx naming the reference and the
    record otherwise (`models.errors`)."""
    ref = group.reference
    joints = as_joint_array(desc, group.joints)
    check_joint_ranges(desc, joints, measured=True)
    values = np.asarray(group.values, dtype=float)
    finite = np.isfinite(values.reshape(group.size, -1)).all(axis=1) if values.size else np.ones(group.size, bool)
    bad = np.flatnonzero(~finite)
    if bad.size:
        raise NonFiniteValue(
            f"{ref.traits.kind} {ref.name!r}, record {int(bad[0])}: its measured value is not a finite number",
            field="measurements",
            pose=int(bad[0]),
        )
    sigma = None if group.sigma_mm is None else np.asarray(group.sigma_mm, dtype=float)
    if sigma is not None and not (sigma.shape == (group.size,) and np.all(np.isfinite(sigma) & (sigma > 0))):
        raise InvalidInput(
            f"{ref.traits.kind} {ref.name!r}: sigma_mm must be one positive number per record", field="sigma_mm"
        )
    return replace(group, joints=joints, values=values, sigma_mm=sigma)


def _registered(desc: RobotDescription, theta: Array, groups: tuple[ReferenceRecords, ...], rt: Runtime) -> Array:
    """With tracker records beside the references, the base from their closed-form registration (the tracker
    may stand metres away and turned: IPOPT starts where the frame already fits); unchanged without."""
    tracked = [g for g in groups if g.reference.traits.registers_frame]
    if not tracked:
        return theta
    joints = np.vstack([g.joints for g in tracked])
    measured = np.vstack([g.values for g in tracked])
    nominal = forward_kinematics(desc, joints, theta, check_ranges=False, runtime=rt).positions
    return registered_base(desc, theta, rigid_fit(nominal, measured))


def _started(desc: RobotDescription, theta: Array, group: ReferenceRecords, rt: Runtime) -> ReferenceRecords:
    """The records with their reference's closed-form start under the start model (`Reference.started`)."""
    tcp = forward_kinematics(desc, group.joints, theta, check_ranges=False, runtime=rt)
    return group.with_reference(group.reference.started(tcp, group.values))


def _estimates(problem: ReferenceProblem, final: Evaluation, u: Array, std: Array) -> tuple[ReferenceEstimate, ...]:
    out = []
    residual_mm = final.residuals[:, 0]
    row = 0
    for k, group in enumerate(problem.groups):
        ref, block = group.reference, slice(problem.blocks[k], problem.blocks[k + 1])
        rows = group.size * ref.traits.rows
        weights = np.repeat(problem.weights[k], ref.traits.rows)
        mm = residual_mm[row : row + rows] / weights
        row += rows
        out.append(
            ReferenceEstimate(
                reference=ref,
                values=u[block],
                std_errors=std[block],
                rms_residual_mm=float(np.sqrt(np.mean(mm**2))),
                records=group.size,
            )
        )
    return tuple(out)


def record_errors(
    desc: RobotDescription, groups: tuple[ReferenceRecords, ...], theta: Array, unknowns: tuple[Array, ...], rt: Runtime
) -> Array:
    """Each campaign record's error in mm under the robot `theta` and each group's reference unknowns, in the
    campaign's order (`ReferenceRecords.positions`): each kind's own (`Reference.errors_mm`: a distance's or a
    touch's |r|, a point's or a position's ‖r‖, an image's points' reprojection errors carried to their depth,
    RMS over the image's points)."""
    order = np.concatenate([g.positions for g in groups])
    errors = np.empty(order.size)
    at = 0
    for group, u in zip(groups, unknowns, strict=True):
        ref = group.reference
        fk = forward_kinematics(desc, group.joints, theta, check_ranges=False, runtime=rt)
        errors[at : at + group.size] = ref.errors_mm(fk, u, group.values)
        at += group.size
    # Several rows of one record (an image's points) make one error: their RMS.
    records, where = np.unique(order, return_inverse=True)
    squares = np.bincount(where, weights=errors**2, minlength=records.size)
    return np.asarray(np.sqrt(squares / np.bincount(where, minlength=records.size)))


@dataclass(frozen=True)
class ReferenceCheck:
    """A parameter version against reference records: the references placed where the records put them under
    that version (their unknowns fitted, the robot held), and what each record then misses by."""

    errors_mm: Array
    """Per record, in the campaign's order."""
    references: tuple[ReferenceRecords, ...]
    """The groups as checked, each with its closed-form start."""
    unknowns: tuple[Array, ...]
    """Each reference's fitted unknowns."""


def check_version(
    desc: RobotDescription,
    groups: tuple[ReferenceRecords, ...],
    theta: Array,
    *,
    noise: NoiseModel | None = None,
    runtime: Runtime | None = None,
) -> ReferenceCheck:
    """How well the version `theta` explains reference records (a ballbar check of a calibrated robot): only
    the references' own unknowns are fitted, so what remains is the geometry's error as these records see it,
    after the best placement of each anchor, point and plane. A length is not needed: the robot is held."""
    rt, noise = runtime_for(desc, runtime), noise or NoiseModel()
    if not groups:
        raise InvalidInput("no reference records: give at least one anchor, point or plane", field="measurements")
    for group in groups:
        group.check()
    groups = tuple(_started(desc, theta, _validated(desc, g), rt) for g in groups)
    u_start = np.concatenate([[s.nominal for s in g.reference.unknowns] for g in groups])
    u_scales = np.concatenate([[s.scale for s in g.reference.unknowns] for g in groups])
    none = np.arange(0, dtype=np.intp)
    problem = ReferenceProblem(desc, rt, groups, noise, theta, none, u_start, u_scales)
    z, _, _ = _solved(problem, IdentificationOptions())
    _, u = problem.split(z)
    unknowns = tuple(u[problem.blocks[k] : problem.blocks[k + 1]] for k in range(len(groups)))
    return ReferenceCheck(record_errors(desc, groups, theta, unknowns, rt), groups, unknowns)
