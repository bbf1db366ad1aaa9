"""Pose designs, one path for every kind of record (issue 43): the request resolved once (`DesignRequest`), the
kind's candidates as the core's problem (`Planned`: a tracker's by `optimal_design.DesignProblem.build`, a
reference's by `service.services.reference_designs`), then one solve or target search and one report."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

from models import NoiseModel, Registry, RobotDescription
from models._types import Array
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime
from models.errors import InvalidInput, TargetUnreachable
from models.measurement import MeasurementKind
from optimal_design import DesignOptions, PoseDesign
from optimal_design.criteria import criterion_of
from optimal_design.problem import DesignInputs, DesignProblem
from optimal_design.solve import solve
from optimal_design.target import Target, target_on
from service.compute.model_cache import ModelCache
from service.conversions.designs import (
    constraints_in,
    design_noise,
    design_public,
    design_summary,
    report_out,
    target_report_out,
)
from service.conversions.kinematics import joints_in
from service.conversions.reference_designs import refuse_unsupported
from service.conversions.terms import design_levels, requested_model, start_values
from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle
from service.record_kinds import BY_MEASUREMENT, RecordKind
from service.schemas.cells import DesignCellPublic
from service.schemas.designs import (
    PoseDesignCreate,
    PoseDesignPublic,
    PoseDesignReportPublic,
    PoseDesignSummaryPublic,
)
from service.services.cells import UsedCell, used_cell
from service.services.fleets import calibration_prior, read_fleet
from service.services.hooks import JobHooks
from service.services.pages import robot_page
from service.services.reference_designs import as_offered, in_records_words, reference_problem_of


@dataclass(frozen=True)
class DesignRequest:
    """A pose design's request resolved once, whatever kind of records it plans: the model to design on (the
    current parameters, with the requested terms), the runtime, the instrument's σ, and the kind."""

    body: PoseDesignCreate
    kind: RecordKind
    desc: RobotDescription
    theta: Array
    runtime: Runtime
    noise: NoiseModel | None


def _as_given(design: PoseDesign) -> tuple[PoseDesign, list[str] | None]:
    return design, None


def _as_raised(exc: TargetUnreachable) -> TargetUnreachable:
    return exc


@dataclass(frozen=True)
class Planned:
    """A kind's candidates as the core's problem, and how its designs are said in the request's words."""

    problem: DesignProblem
    offered: Callable[[PoseDesign], tuple[PoseDesign, list[str] | None]] = _as_given
    """The design with its indices into the request's candidates, and the reference each chosen record measures
    (None: a tracker's records measure none)."""
    unreachable: Callable[[TargetUnreachable], TargetUnreachable] = _as_raised
    """An unreachable target in the records' words."""
    cell: UsedCell | None = None


def create_design(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    body: PoseDesignCreate,
    job: JobHooks | None = None,
) -> PoseDesignPublic:
    """The new design as stored, designed with the robot's current parameters (and stored with
    the job's own `succeeded` when run as one)."""
    if job is not None:
        job.progress("reading", 0.0)
    request = _resolved(models, registry, robot_id, body)
    # The planned kind's capability says where its candidates come from: a whole campaign's (a tracker's, with
    # its cell and prior) or records grouped by the references they measure.
    if request.kind.whole_campaign:
        planned = _tracker_planned(db, models, registry, robot_id, request)
    else:
        problem, found = reference_problem_of(request.desc, request.theta, body, request.runtime, request.noise)
        planned = Planned(problem, lambda design: as_offered(design, found), in_records_words)
    if job is not None:
        job.progress("designing", 0.05)
    report = _designed(request, planned).model_dump(mode="json")
    if job is not None:
        job.progress("storing", 0.95)
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)  # still there
        record = repo.add_design(robot_id, body.model_dump(mode="json"), report)
        if job is not None:
            job.commit(s, record.id)
        return design_public(record)


def _resolved(models: ModelCache, registry: Registry, robot_id: str, body: PoseDesignCreate) -> DesignRequest:
    """The request's kind, model and σ; the options its kind does not take refused first, each named."""
    kind = BY_MEASUREMENT[str(body.measurement)]
    if not kind.whole_campaign:
        refuse_unsupported(body)
    desc, theta = models.current(robot_id)
    if body.terms:
        # A design for a calibration with model terms: their columns, at the levels the user can set.
        if body.target is not None:
            raise InvalidInput("terms: a design with model terms takes a count, not a target", field="terms")
        desc = requested_model(desc, body.terms)
        theta = start_values(desc, theta)
    return DesignRequest(body, kind, desc, theta, registry.runtime(desc), design_noise(body))


@single_threaded_blas
def _designed(request: DesignRequest, planned: Planned) -> PoseDesignReportPublic:
    """The design of a planned problem, count or target, as its report: the cell's refusals and the chosen
    records' references with it, the measurement as asked."""
    started = time.perf_counter()
    body, desc, problem = request.body, request.desc, planned.problem
    given = body.candidates is not None
    names: list[str] | None = None
    if body.target is not None:
        target = Target.of(body.target.rms_tcp_mm, body.target.max_tcp_mm, body.criterion)
        # The core labels a target's report by the rows it weighs: a reference's records are position rows.
        rows = body.measurement if request.kind.whole_campaign else MeasurementKind.POSITION
        try:
            found = target_on(desc, problem, target, seed=body.seed, measurement=str(rows), started=started)
        except TargetUnreachable as exc:
            raise planned.unreachable(exc) from exc
        if found.design is not None:  # None: what was measured already reaches the target
            design, names = planned.offered(found.design)
            found = replace(found, design=design)
        report = target_report_out(desc, found, candidates_given=given, criterion=body.criterion)
    else:
        assert body.count is not None  # the schema asks for count or target
        chosen = solve(
            desc,
            problem,
            criterion_of(body.criterion),
            body.count,
            seed=body.seed,
            started=started,
            d_efficiency_floor=body.d_efficiency_floor,
            bound_seconds=body.bound_seconds,
        )
        design, names = planned.offered(chosen)
        report = report_out(desc, design, candidates_given=given)
    if not request.kind.whole_campaign:
        # The core designs a reference's records as position rows: the report names what was asked.
        report = PoseDesignReportPublic.model_validate(
            {**report.model_dump(), "measurement": body.measurement, "references": names or []}
        )
    return _with_cell(report, planned.cell)


def _tracker_planned(
    db: Database, models: ModelCache, registry: Registry, robot_id: str, request: DesignRequest
) -> Planned:
    """A tracker's candidates (pose or position) as the core's problem, with the cell and the fleet's prior."""
    body, desc = request.body, request.desc
    common = _problem(request)
    cell = None
    if body.cell is not None:
        cell = used_cell(db=db, models=models, registry=registry, robot_id=robot_id, cell=body.cell)
        common["cell"] = cell.cell
    if body.prior == "fleet":
        with db.reader() as s:
            fleet = read_fleet(s, Repository(s).robot(robot_id))
        common["prior"] = calibration_prior(fleet, robot_id, desc, None)
    # Built with one BLAS thread, as the design that follows (`_designed`) and the library's entry points are.
    problem = single_threaded_blas(DesignProblem.build)(desc, DesignInputs(measurement=str(body.measurement), **common))
    return Planned(problem, cell=cell)


def _with_cell(report: PoseDesignReportPublic, cell: UsedCell | None) -> PoseDesignReportPublic:
    """The report with what the cell refused: its reasons among the filters' counts (the joint sub-ranges and
    the keep-out box run first, so the cell checked what they passed)."""
    if cell is None:
        return report
    constraints = report.constraints
    offered = constraints.offered if constraints is not None else 0
    excluded = dict(constraints.excluded) if constraints is not None else {}
    checked = offered - excluded.pop("joint_ranges", 0) - excluded.pop("keep_out", 0)
    found = DesignCellPublic(
        version=cell.version, checked=checked, feasible=checked - sum(excluded.values()), refused=excluded
    )
    return report.model_copy(update={"cell": found})


def _problem(request: DesignRequest) -> DesignOptions:
    """A tracker's design options in internal units (`optimal_design.DesignOptions`)."""
    body, desc = request.body, request.desc
    levels = design_levels(desc, body.temperature_levels_c, body.payload_levels)
    if body.candidates is not None and not body.candidates:
        raise InvalidInput("candidates is empty: give at least `count` joint vectors, or omit them", field="candidates")
    joint_ranges, keep_out = constraints_in(desc, body)
    tracker, fixed = body.joint_candidates(), body.joint_fixed()
    return DesignOptions(
        candidates=joints_in(desc, tracker) if tracker is not None else None,
        candidate_count=body.candidate_count,
        seed=body.seed,
        fixed=joints_in(desc, fixed) if fixed is not None else None,
        params=request.theta,
        joint_ranges=joint_ranges,
        keep_out=keep_out,
        min_spread=body.min_spread,
        noise=request.noise,
        runtime=request.runtime,
        levels=levels,  # None without model terms, which the target mode refuses in `_resolved`
    )


def get_design(*, db: Database, design_id: str) -> PoseDesignPublic:
    with db.reader() as s:
        return design_public(Repository(s).design(design_id))


def list_designs(*, db: Database, robot_id: str, limit: int, offset: int) -> list[PoseDesignSummaryPublic]:
    return robot_page(db, robot_id, Lifecycle.designs, design_summary, limit=limit, offset=offset)
