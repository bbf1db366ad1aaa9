from __future__ import annotations

import numpy as np

from models import RobotDescription
from models.description.structure import description_from_document
from models.formats.urdf import document_from_urdf
from service.audit_actions import AuditAction
from service.compute.builds import StructureBuilds
from service.conversions.robots import (
    around_urdf,
    build_out,
    description,
    frame_in,
    new_description,
    parameters_out,
    robot_out,
    structure_out,
    urdf_source,
)
from service.conversions.terms import stored_model
from service.errors import Conflict
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle, check_revision, etag
from service.persistence.tables import Robot
from service.schemas.robots import ParametersPublic, RobotCreate, RobotPatch, RobotPublic
from service.schemas.structure import StructureDocument

NO_ACTOR = Actor()


def create_robot(
    *, db: Database, body: RobotCreate, actor: Actor = NO_ACTOR, builds: StructureBuilds | None = None
) -> RobotPublic:
    """The new robot, stored; its structure's build starts in the background (`build` on the answer)."""
    new = new_description(body)  # InvalidInput (a 422 naming the field) for a bad document
    desc = new.desc
    nominal = desc.parameters.nominal.tolist()
    model = "iwr" if new.document is None else "custom"
    with db.session() as s:
        repo = Repository(s)
        _name_is_free(repo, body.name)
        robot = repo.add_robot(
            body.name, model, list(desc.base), list(desc.tool), nominal, structure=new.document, urdf=new.urdf
        )
        repo.version(robot.id, 1).actor = actor.name
        Lifecycle(s).changed(
            robot, AuditAction.ROBOT_CREATED, actor, version=1, details={"name": robot.name}, bump=False
        )
        created = robot_out(robot)
    # After the commit: a build is never started for a robot that was not stored.
    return _with_build(created, desc, builds, start=True)


def _with_build(
    out: RobotPublic, desc: RobotDescription, builds: StructureBuilds | None, *, start: bool
) -> RobotPublic:
    """`out` with its structure's build state (`start`: the build started if this process has none)."""
    if builds is None:
        return out
    status = builds.ensure(desc) if start else builds.status(desc)
    return out if status is None else out.model_copy(update={"build": build_out(status)})


def _robot_out(robot: Robot, builds: StructureBuilds | None, *, start: bool) -> RobotPublic:
    return _with_build(robot_out(robot), description(robot), builds, start=start)


def _name_is_free(repo: Repository, name: str) -> None:
    """Robot names are unique in a service: a plant finds its cells by name, and two "cell-3" would be calibrated
    into each other's parameters."""
    taken = repo.robot_named(name)
    if taken is not None:
        raise Conflict(f"a robot named {name!r} exists already (id {taken.id}): choose another name", id=taken.id)


def list_robots(*, db: Database, limit: int, offset: int) -> list[RobotPublic]:
    with db.reader() as s:
        return [robot_out(r) for r in Repository(s).robots(limit, offset)]


def get_robot(*, db: Database, robot_id: str, builds: StructureBuilds | None = None) -> RobotPublic:
    """The robot; after a restart, reading it starts its structure's build (cheap when the libraries are
    cached on disk)."""
    with db.reader() as s:
        return _robot_out(Repository(s).robot(robot_id), builds, start=True)


def patch_robot(
    *,
    db: Database,
    robot_id: str,
    body: RobotPatch,
    actor: Actor = NO_ACTOR,
    if_match: str | None = None,
    builds: StructureBuilds | None = None,
) -> RobotPublic:
    """Name and notes change in place; new base or tool guesses also make a new current version (provenance
    `edit`) where those parameters take the guess and every other parameter keeps the current version's value."""
    given = body.model_fields_set
    base = frame_in(body.base, "base") if "base" in given and body.base is not None else None
    tool = frame_in(body.tool, "tool") if "tool" in given and body.tool is not None else None
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        robot = repo.robot(robot_id, lock=True)
        check_revision(robot, if_match)
        source = urdf_source(robot)
        if source is not None and (base is not None or tool is not None):
            # As at creation: world <- base_link and tip_link -> TCP, around the URDF's own frames.
            imported = description_from_document(document_from_urdf(source.urdf, source.base_link, source.tip_link))
            base, tool = around_urdf(imported, base, tool)
        changed: list[str] = []
        if "name" in given and body.name is not None and body.name != robot.name:
            _name_is_free(repo, body.name)
            robot.name, changed = body.name, [*changed, "name"]
        if "notes" in given and (body.notes or None) != robot.notes:
            robot.notes, changed = body.notes or None, [*changed, "notes"]
        frames = {}
        if base is not None and list(base) != robot.base:
            frames["base"] = base
        if tool is not None and list(tool) != robot.tool:
            frames["tool"] = tool
        if frames:
            previous = repo.version(robot_id)
            values = np.asarray(previous.values, dtype=float)
            std = list(previous.std_errors or [None] * len(values))
            ident = list(previous.identifiable or [None] * len(values))
            slices = description(robot).slices
            for what, frame in frames.items():
                values[slices[what]] = frame
                for i in range(*slices[what].indices(len(values))):
                    std[i], ident[i] = None, None  # a guess, not an estimate
                setattr(robot, what, list(frame))
            new = life.add_version(
                robot, values=values.tolist(), std_errors=std, identifiable=ident, provenance="edit", actor=actor
            )
            changed += sorted(frames)
            details = {"from_version": previous.version, "changed": sorted(frames)}
            life.changed(robot, AuditAction.VERSION_EDITED, actor, version=new, details=details, bump=False)
        if changed:  # one revision per PATCH, whatever it changed
            life.changed(
                robot, AuditAction.ROBOT_UPDATED, actor, version=robot.current_version, details={"changed": changed}
            )
        return _robot_out(robot, builds, start=False)


def delete_robot(*, db: Database, robot_id: str, actor: Actor = NO_ACTOR, if_match: str | None = None) -> None:
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        robot = repo.robot(robot_id, lock=True)
        check_revision(robot, if_match)
        life.changed(
            robot, AuditAction.ROBOT_DELETED, actor, version=robot.current_version, details={"name": robot.name}
        )
        life.delete_validations(robot_id)
        repo.delete_robot(robot_id)


def get_parameters(*, db: Database, robot_id: str, version: int | None) -> tuple[ParametersPublic, str]:
    with db.reader() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id)
        row = repo.version(robot_id, version)
        return parameters_out(stored_model(description(robot), len(row.values)), row), etag(robot)


def get_structure(*, db: Database, robot_id: str, version: int | None) -> StructureDocument:
    """The robot's description document with the values of a parameter version (POST /v1/robots takes it)."""
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
    return structure_out(desc, values[: desc.n_params])  # the geometry (the terms' values: /parameters)
