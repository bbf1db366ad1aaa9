"""Robots of several chains (issue 47): POST a tree (branches or a URDF with tip links), GET one or the list,
DELETE; each tool's pose and each tool in another's frame at joints by name; calibrations from any tool's
records, applied as a new revision of the tree's parameters (If-Match on the tree's ETag); a record design over
the tree, compensated joints for targets in the world or in another tool's frame, and the calibrated tree
exported (its URDF, its branches' DH tables)."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Header, Query, Request, Response
from fastapi.concurrency import run_in_threadpool

from service.compute import limits
from service.http.deps import (
    JSON_OR_CSV,
    ActorDep,
    ComputeDep,
    DatabaseDep,
    Limit,
    Offset,
    RegistryDep,
    requested_media,
)
from service.http.json_bodies import OffloopRoute
from service.http.operations import Runs, operation
from service.http.responses import model_json, models_json
from service.http.security import Scope
from service.routes.reports import REPORT_RESPONSES, Report, ReportFormat
from service.schemas.robot_trees import (
    RobotTreeCreate,
    RobotTreePublic,
    TreeCalibrationCreate,
    TreeCalibrationPublic,
    TreeCompensationCreate,
    TreeCompensationPublic,
    TreeDesignCreate,
    TreeDesignPublic,
    TreeDhExportPublic,
    TreeKinematicsPublic,
    TreeKinematicsRequest,
    TreeMeasured,
    TreeUrdfExportPublic,
)
from service.services import robot_trees, tree_operations, tree_reports

router = APIRouter(prefix="/v1/robot-trees", tags=["robot-trees"], route_class=OffloopRoute)
IfMatch = Annotated[str | None, Header(description="The tree's ETag as last read: 412 when it has changed since")]
_PRECONDITION: dict[int | str, dict[str, Any]] = {412: {"description": "If-Match is stale"}}


@router.post("", status_code=201, response_model=RobotTreePublic)
@operation(Scope.write)
def create_robot_tree(body: RobotTreeCreate, db: DatabaseDep, actor: ActorDep) -> Response:
    """A tree from its branches (each a robots.md chain of stages, its parent, mount, tool, joint names) or from
    a URDF and the links that carry its tools. A 422 names the field: a duplicate name, an unknown parent, a
    cycle, an end branch without a tool, too many links or joints, a xacro (with the command to expand it)."""
    tree, etag = robot_trees.create_tree(db=db, body=body, actor=actor)
    return model_json(tree, status_code=201, etag=etag)


@router.get("", response_model=list[RobotTreePublic])
@operation(Scope.read)
def list_robot_trees(db: DatabaseDep, limit: Limit = 100, offset: Offset = 0) -> Response:
    return models_json(robot_trees.list_trees(db=db, limit=limit, offset=offset), RobotTreePublic)


@router.get("/{tree_id}", response_model=RobotTreePublic)
@operation(Scope.read)
def get_robot_tree(tree_id: str, db: DatabaseDep) -> Response:
    """The tree: its branches (parents, children, mounts, tools, joints, stages), its parameters by name and group
    with their current values (the last applied calibration's, else nominal)."""
    tree, etag = robot_trees.get_tree(db=db, tree_id=tree_id)
    return model_json(tree, etag=etag)


@router.delete("/{tree_id}", status_code=204, responses=_PRECONDITION)
@operation(Scope.admin)
def delete_robot_tree(tree_id: str, db: DatabaseDep, actor: ActorDep, if_match: IfMatch = None) -> Response:
    robot_trees.delete_tree(db=db, tree_id=tree_id, actor=actor, if_match=if_match)
    return Response(status_code=204)


@router.post("/{tree_id}/kinematics", response_model=TreeKinematicsPublic)
@operation(Scope.read, runs=Runs.COMPUTE)
async def robot_tree_kinematics(
    tree_id: str,
    *,
    body: TreeKinematicsRequest,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    """Per joint vector (by name, or in the tree's order; deg and mm): each tool's pose in the world frame,
    each tool in every other tool's frame (`a/b`), and with `frames` every frame of every branch once and each
    tool's chain of frame names, to draw the tree. The tree's current parameters."""
    size = await run_in_threadpool(robot_trees.tree_size, db=db, tree_id=tree_id)
    cost = limits.tree_kinematics(len(body.joints), size.tools, size.frames if body.frames else 0)
    on_tree = {"db": db, "registry": registry, "tree_id": tree_id, "body": body}
    found = await compute.admitted(cost, "tree_kinematics", robot_trees.kinematics, **on_tree)
    return model_json(found)


@router.post(
    "/{tree_id}/calibrations",
    status_code=201,
    response_model=TreeCalibrationPublic,
    responses={**_PRECONDITION, 409: {"description": "The tree changed during the fit: stored, not applied"}},
)
@operation(Scope.write, runs=Runs.COMPUTE)
async def create_robot_tree_calibration(
    tree_id: str,
    *,
    body: TreeCalibrationCreate,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    actor: ActorDep,
    if_match: IfMatch = None,
) -> Response:
    """The tree's parameters from records of its tools (each naming the `tool` it measured, in the instrument's
    frame or in another tool's `frame`), with held-out records judged after the fit: the fit's and the held-out
    RMS per tool, each tool's predicted accuracy and each pair's RELATIVE accuracy (one tool in the other's
    frame). Applied (the default) it becomes the tree's parameters, a new revision."""
    size = await run_in_threadpool(robot_trees.tree_size, db=db, tree_id=tree_id)
    records = len(body.records) + len(body.held_out)
    cost = limits.tree_calibration(records, size.parameters)
    on_tree = {"db": db, "registry": registry, "tree_id": tree_id, "body": body}
    found = await compute.admitted(
        cost, "tree_calibration", robot_trees.calibrate, actor=actor, if_match=if_match, **on_tree
    )
    return model_json(found, status_code=201)


@router.get("/{tree_id}/calibrations", response_model=list[TreeCalibrationPublic])
@operation(Scope.read)
def list_robot_tree_calibrations(tree_id: str, db: DatabaseDep, limit: Limit = 100, offset: Offset = 0) -> Response:
    return models_json(
        robot_trees.calibrations(db=db, tree_id=tree_id, limit=limit, offset=offset), TreeCalibrationPublic
    )


@router.get("/{tree_id}/calibrations/{calibration_id}", response_model=TreeCalibrationPublic)
@operation(Scope.read)
def get_robot_tree_calibration(tree_id: str, calibration_id: str, db: DatabaseDep) -> Response:
    return model_json(robot_trees.calibration(db=db, tree_id=tree_id, calibration_id=calibration_id))


_TREE_REPORT = Report("tree_report", tree_reports.tree_report_html, tree_reports.tree_report_pdf)


@router.get("/{tree_id}/calibrations/{calibration_id}/report", response_class=Response, responses=REPORT_RESPONSES)
@operation(Scope.read, runs=Runs.COMPUTE)
async def robot_tree_calibration_report(
    tree_id: str,
    calibration_id: str,
    *,
    request: Request,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    format: ReportFormat = None,
) -> Response:
    """The calibration's report: the tree's branches, each tool's fit and held-out error (a figure and a table),
    each tool's and pair's predicted accuracy as the calibration states it, and a figure of each pair's RELATIVE
    position accuracy over joint vectors of the measured region (predicted after, moved by the fit ≈ before)."""
    kwargs = {"db": db, "registry": registry, "tree_id": tree_id, "calibration_id": calibration_id}
    return await _TREE_REPORT.answer(compute, request, format, f"tree-calibration-{calibration_id}", **kwargs)


_CSV = {"text/csv": {"schema": {"type": "string"}}}
_URDF_OR_JSON = {"urdf": "application/xml", "json": "application/json"}


@router.post(
    "/{tree_id}/designs",
    response_model=TreeDesignPublic,
    responses={
        200: {"content": {**_CSV}, "description": "JSON, or with Accept: text/csv the chosen records"},
        406: {"description": "Accept allows neither JSON nor CSV"},
    },
)
@operation(Scope.read, runs=Runs.COMPUTE)
async def design_robot_tree_records(
    tree_id: str,
    *,
    body: TreeDesignCreate,
    request: Request,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
    format: Literal["json", "csv"] | None = Query(None, description="json (the default) or csv; or by Accept"),
) -> Response:
    """Which records to take of the tree's tools (`measure`: each tool's position or pose, in the instrument's
    frame or in another tool's), `count` of the candidates chosen for a criterion of GET /v1/design-criteria,
    at the tree's current parameters: the records (tool, frame, joints by name), the criterion's value and
    efficiency, the same metrics for random selections of as many, and each tool's and pair's predicted accuracy
    after calibrating from them (and from the random ones). Nothing is stored; with ?format=csv (or Accept:
    text/csv) the records as a campaign sheet (tool, frame, measurement, the tree's joints)."""
    size = await run_in_threadpool(robot_trees.tree_size, db=db, tree_id=tree_id)
    records = body.offered(size.tools)
    rows = TreeMeasured.most_rows(body.measure)
    cost = limits.tree_design(records, rows, size.parameters, body.count, body.criterion.value)
    on_tree = {"db": db, "registry": registry, "tree_id": tree_id, "body": body}
    found = await compute.admitted(cost, "tree_design", tree_operations.design, **on_tree)
    if requested_media(request, format, JSON_OR_CSV) == "text/csv":
        names = await run_in_threadpool(tree_operations.joint_names, db=db, tree_id=tree_id)
        return Response(tree_operations.design_csv(names, found), media_type="text/csv")
    return model_json(found)


@router.post("/{tree_id}/compensations", response_model=TreeCompensationPublic)
@operation(Scope.read, runs=Runs.COMPUTE)
async def compensate_robot_tree_targets(
    tree_id: str,
    *,
    body: TreeCompensationCreate,
    db: DatabaseDep,
    registry: RegistryDep,
    compute: ComputeDep,
) -> Response:
    """Per target (a tool's pose in the world, or in another tool's `frame`: the torch in the positioner's part
    frame), with the program's joints: the joints that put the tool there on the tree's current (calibrated)
    parameters, next to the program's. Only the tool's own branches move; the frame tool's and any branch it
    shares with another tool are kept. A target left as given says why (out of a joint's range, near a singular
    configuration or the edge of the reach, only on another configuration)."""
    cost = limits.tree_compensation(len(body.targets))
    on_tree = {"db": db, "registry": registry, "tree_id": tree_id, "body": body}
    found = await compute.admitted(cost, "tree_compensation", tree_operations.compensate, **on_tree)
    return model_json(found)


@router.get(
    "/{tree_id}/exports/urdf",
    response_model=TreeUrdfExportPublic,
    responses={
        200: {"content": {"application/xml": {"schema": {"type": "string"}}}},
        406: {"description": "Accept allows neither XML nor JSON"},
    },
)
@operation(Scope.read)
def export_robot_tree_urdf(
    tree_id: str,
    request: Request,
    db: DatabaseDep,
    format: Literal["urdf", "json"] | None = Query(
        None, description="urdf (the default, or Accept: application/xml) or json (the URDF with its frames beside)"
    ),
) -> Response:
    """A tree imported from a URDF, calibrated: the same URDF with its moving joints' origins calibrated (a
    drop-in), world <- base_link and each tip -> its TCP in a comment at its top and, as JSON, beside it. A 422
    for a tree given as a document (no URDF to write into: export its DH tables)."""
    found = tree_operations.urdf_export(db=db, tree_id=tree_id)
    if requested_media(request, format, _URDF_OR_JSON) == "application/json":
        return model_json(found.public)
    return Response(found.xml, media_type="application/xml")


@router.get(
    "/{tree_id}/exports/dh",
    response_model=TreeDhExportPublic,
    responses={200: {"content": {**_CSV}}, 406: {"description": "Accept allows neither JSON nor CSV"}},
)
@operation(Scope.read)
def export_robot_tree_dh(
    tree_id: str,
    request: Request,
    db: DatabaseDep,
    format: Literal["json", "csv"] | None = Query(None, description="json (the default) or csv; or by Accept"),
) -> Response:
    """Each branch of serial stages as its calibrated DH (or MDH) table, from its parent's end frame (the world
    for a branch from the base) to its end, and its tool: JSON, or one CSV sheet (a base row, a row per link, a
    tool row per branch). Branches without serial stages are listed in `left_out`."""
    found = tree_operations.dh_export(db=db, tree_id=tree_id)
    if requested_media(request, format, JSON_OR_CSV) == "text/csv":
        return Response(tree_operations.dh_csv(found), media_type="text/csv")
    return model_json(found)
