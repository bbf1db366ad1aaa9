"""A robot's cell: stored in versions (each PUT and DELETE adds one), read back with its effective geometry, and
used to check poses and to design among those it can measure."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models import Registry, RobotDescription
from models.cell import Cell, check_poses
from models.errors import InvalidInput
from service.compute.model_cache import ModelCache
from service.conversions.cells import EffectiveCell, cell_in, cell_public, cell_version_out
from service.conversions.kinematics import joints_in
from service.conversions.robots import urdf_source
from service.errors import NotFound
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle, check_revision
from service.persistence.tables import RobotCellRecord
from service.schemas.cells import CellCheckCreate, CellCheckPublic, CellDocument, CellPublic, CellVersionPublic

NO_ACTOR = Actor()


@dataclass(frozen=True)
class UsedCell:
    """The models' cell a check or a design uses, and its stored version (None: a document sent inline)."""

    cell: Cell
    version: int | None


def _effective(
    db: Database, models: ModelCache, registry: Registry, robot_id: str, doc: CellDocument
) -> tuple[RobotDescription, EffectiveCell]:
    desc, _ = models.current(robot_id)
    with db.reader() as s:
        source = urdf_source(Repository(s).robot(robot_id))
    return desc, cell_in(desc, doc, source, registry.runtime(desc))


def _missing(robot_id: str, version: int | None, record: RobotCellRecord | None) -> NotFound:
    if record is None and version is not None:
        what = f"robot {robot_id!r} has no cell version {version}"
    elif record is None:
        what = f"robot {robot_id!r} has no cell: PUT /v1/robots/{robot_id}/cell describes it"
    else:
        what = f"robot {robot_id!r}'s cell version {record.version} ended it (DELETE): no cell then"
    return NotFound(what, resource="cell")


def put_cell(
    *,
    db: Database,
    models: ModelCache,
    registry: Registry,
    robot_id: str,
    body: CellDocument,
    actor: Actor = NO_ACTOR,
    if_match: str | None = None,
) -> tuple[CellPublic, str]:
    """A new version of the robot's cell, checked against the robot first (a 422 names what does not fit it:
    a body it does not have, an obstacle named like one of its bodies), and the robot's new ETag."""
    _, effective = _effective(db, models, registry, robot_id, body)
    with db.session() as s:
        robot = Repository(s).robot(robot_id, lock=True)
        check_revision(robot, if_match)
        record = Lifecycle(s).add_cell(robot, body.model_dump(mode="json"), actor)
        return cell_public(robot_id, record, effective), f'"{robot.revision}"'


def get_cell(*, db: Database, models: ModelCache, registry: Registry, robot_id: str, version: int | None) -> CellPublic:
    """The current cell (or a past version) with the geometry and allowed pairs it has on the robot now."""
    with db.reader() as s:
        Repository(s).robot(robot_id)
        record = Lifecycle(s).cell(robot_id, version)
    if record is None or record.document is None:
        raise _missing(robot_id, version, record)
    doc = CellDocument.model_validate(record.document)
    _, effective = _effective(db, models, registry, robot_id, doc)
    return cell_public(robot_id, record, effective)


def cell_versions(*, db: Database, robot_id: str, limit: int, offset: int) -> list[CellVersionPublic]:
    with db.reader() as s:
        Repository(s).robot(robot_id)
        return [cell_version_out(r) for r in Lifecycle(s).cells(robot_id, limit, offset)]


def delete_cell(*, db: Database, robot_id: str, actor: Actor = NO_ACTOR, if_match: str | None = None) -> str:
    """Ends the robot's cell with a version of its own (the earlier versions stay readable); the new ETag."""
    with db.session() as s:
        robot = Repository(s).robot(robot_id, lock=True)
        check_revision(robot, if_match)
        life = Lifecycle(s)
        current = life.cell(robot_id)
        if current is None or current.document is None:
            raise _missing(robot_id, None, current)
        life.add_cell(robot, None, actor)
        return f'"{robot.revision}"'


def used_cell(
    *, db: Database, models: ModelCache, registry: Registry, robot_id: str, cell: str | CellDocument
) -> UsedCell:
    """The cell a request names: `stored` (the robot's current one; a 422 when it has none) or a document."""
    if isinstance(cell, CellDocument):
        return UsedCell(_effective(db, models, registry, robot_id, cell)[1].cell, None)
    with db.reader() as s:
        Repository(s).robot(robot_id)
        record = Lifecycle(s).cell(robot_id)
    if record is None or record.document is None:
        raise InvalidInput(
            f"cell 'stored': robot {robot_id!r} has no cell now (PUT /v1/robots/{robot_id}/cell, or send one)",
            field="cell",
        )
    doc = CellDocument.model_validate(record.document)
    return UsedCell(_effective(db, models, registry, robot_id, doc)[1].cell, record.version)


def check_cell(
    *, db: Database, models: ModelCache, registry: Registry, robot_id: str, body: CellCheckCreate
) -> CellCheckPublic:
    """Each pose's verdict against the cell, with the robot's current parameters (joints in mm and degrees)."""
    used = used_cell(db=db, models=models, registry=registry, robot_id=robot_id, cell=body.cell)
    desc, theta = models.current(robot_id)
    q = joints_in(desc, body.poses)
    found = check_poses(desc, used.cell, q, theta, runtime=registry.runtime(desc))
    poses = [
        {"feasible": bool(ok), "reason": reason or None, "detail": detail or None}
        for ok, reason, detail in zip(found.feasible.tolist(), found.reasons, found.details, strict=True)
    ]
    return CellCheckPublic.model_validate(
        {
            "cell_version": used.version,
            "feasible": int(np.count_nonzero(found.feasible)),
            "refused": found.counts,
            "poses": poses,
        }
    )
