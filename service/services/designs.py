from __future__ import annotations

from models import Registry, RobotDescription
from models.errors import InvalidInput
from models.measurement import MeasurementKind
from optimal_design import DesignOptions, design_for_target, design_poses
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
from service.conversions.terms import design_levels, requested_model, start_values
from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle
from service.record_kinds import BY_MEASUREMENT
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
from service.services.reference_designs import reference_report


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
    # One dispatch, by the planned kind's capability: a whole campaign's design (a tracker's, with its cell,
    # prior, terms and target modes) or the design of records grouped by the references they measure.
    if not BY_MEASUREMENT[str(body.measurement)].whole_campaign:
        if body.cell is not None:
            raise InvalidInput(
                "cell: designs among the poses a cell can measure are of a tracker's records (pose or position) "
                "for now",
                field="cell",
            )
        if body.prior != "none":
            raise InvalidInput(
                "prior fleet designs tracker poses: a reference campaign's fit takes no prior yet", field="prior"
            )
        desc, theta = models.current(robot_id)
        if job is not None:
            job.progress("designing", 0.05)
        report_model = reference_report(desc, theta, body, registry.runtime(desc))
    else:
        report_model = _tracker_report(db, models, registry, robot_id, body, job=job)
    report = report_model.model_dump(mode="json")
    if job is not None:
        job.progress("storing", 0.95)
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)  # still there
        record = repo.add_design(robot_id, body.model_dump(mode="json"), report)
        if job is not None:
            job.commit(s, record.id)
        return design_public(record)


def _tracker_report(
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    body: PoseDesignCreate,
    *,
    job: JobHooks | None,
) -> PoseDesignReportPublic:
    """A design of a tracker's poses (pose or position), count or target."""
    desc, common = _problem(models, registry, robot_id, body)
    cell = None
    if body.cell is not None:
        cell = used_cell(db=db, models=models, registry=registry, robot_id=robot_id, cell=body.cell)
        common["cell"] = cell.cell
    if body.prior == "fleet":
        with db.reader() as s:
            fleet = read_fleet(s, Repository(s).robot(robot_id))
        common["prior"] = calibration_prior(fleet, robot_id, desc, None)
    if job is not None:
        job.progress("designing", 0.05)
    assert isinstance(body.measurement, MeasurementKind)  # the reference kinds are designed apart
    if body.target is not None:
        found = design_for_target(
            desc,
            rms_tcp_mm=body.target.rms_tcp_mm,
            max_tcp_mm=body.target.max_tcp_mm,
            criterion=body.criterion,
            measurement=body.measurement,
            **common,
        )
        report = target_report_out(desc, found, candidates_given=body.candidates is not None, criterion=body.criterion)
        return _with_cell(report, cell)
    assert body.count is not None  # the schema asks for count or target
    design = design_poses(
        desc,
        body.count,
        body.criterion,
        body.measurement,
        d_efficiency_floor=body.d_efficiency_floor,
        bound_seconds=body.bound_seconds,
        **common,
    )
    return _with_cell(report_out(desc, design, candidates_given=body.candidates is not None), cell)


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


def _problem(
    models: ModelCache, registry: Registry, robot_id: str, body: PoseDesignCreate
) -> tuple[RobotDescription, DesignOptions]:
    """The model to design on (the current parameters, with the requested terms) and the request's options in
    internal units."""
    desc, theta = models.current(robot_id)
    if body.terms:
        # A design for a calibration with model terms: their columns, at the levels the user can set.
        if body.target is not None:
            raise InvalidInput("terms: a design with model terms takes a count, not a target", field="terms")
        desc = requested_model(desc, body.terms)
        theta = start_values(desc, theta)
    levels = design_levels(desc, body.temperature_levels_c, body.payload_levels)
    if body.candidates is not None and not body.candidates:
        raise InvalidInput("candidates is empty: give at least `count` joint vectors, or omit them", field="candidates")
    joint_ranges, keep_out = constraints_in(desc, body)
    tracker, fixed = body.joint_candidates(), body.joint_fixed()
    options = DesignOptions(
        candidates=joints_in(desc, tracker) if tracker is not None else None,
        candidate_count=body.candidate_count,
        seed=body.seed,
        fixed=joints_in(desc, fixed) if fixed is not None else None,
        params=theta,
        joint_ranges=joint_ranges,
        keep_out=keep_out,
        min_spread=body.min_spread,
        noise=design_noise(body),
        runtime=registry.runtime(desc),
        levels=levels,  # None without model terms, which the target mode refuses above
    )
    return desc, options


def get_design(*, db: Database, design_id: str) -> PoseDesignPublic:
    with db.reader() as s:
        return design_public(Repository(s).design(design_id))


def list_designs(*, db: Database, robot_id: str, limit: int, offset: int) -> list[PoseDesignSummaryPublic]:
    return robot_page(db, robot_id, Lifecycle.designs, design_summary, limit=limit, offset=offset)
