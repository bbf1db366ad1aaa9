"""Parameter versions: list, diff, restore and import. A version is never changed or deleted: a restore or an
import is a new version that becomes current, recorded in the audit trail with who asked."""

from __future__ import annotations

from models.errors import InvalidInput
from service.audit_actions import AuditAction
from service.conversions.robots import description
from service.conversions.terms import requested_model, stored_model
from service.conversions.versions import diff_out, import_in, version_out
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle, check_revision, etag
from service.persistence.tables import ParameterVersion
from service.schemas.versions import ParameterVersionImport, ParameterVersionPublic, VersionDiffPublic


def _existing(repo: Repository, robot_id: str, version: int, field: str) -> ParameterVersion:
    latest = repo.latest_version(robot_id)
    if not 1 <= version <= latest:
        raise InvalidInput(
            f"{field}: version {version} does not exist; robot {robot_id!r} has versions 1 to {latest}", field=field
        )
    return repo.version(robot_id, version)


def list_versions(*, db: Database, robot_id: str) -> tuple[list[ParameterVersionPublic], str]:
    """Oldest first, with the robot's ETag."""
    with db.reader() as s:
        robot = Repository(s).robot(robot_id)
        rows = Lifecycle(s).versions(robot_id)
        return [version_out(r, robot.current_version) for r in rows], etag(robot)


def diff(*, db: Database, robot_id: str, a: int, b: int) -> VersionDiffPublic:
    with db.reader() as s:
        repo = Repository(s)
        row_a, row_b = _existing(repo, robot_id, a, "a"), _existing(repo, robot_id, b, "b")
        # The model of the version with more values: the terms one of them was calibrated with, if any.
        desc = stored_model(description(repo.robot(robot_id)), max(len(row_a.values), len(row_b.values)))
        return diff_out(desc, robot_id, row_a, row_b)


def restore(
    *, db: Database, robot_id: str, version: int, actor: Actor, if_match: str | None
) -> tuple[ParameterVersionPublic, str]:
    """A new current version equal to `version` (values, std errors, identifiable flags)."""
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        robot = repo.robot(robot_id, lock=True)
        check_revision(robot, if_match)
        source = _existing(repo, robot_id, version, "version")
        previous = robot.current_version
        new = life.add_version(
            robot,
            values=list(source.values),
            std_errors=source.std_errors,
            identifiable=source.identifiable,
            provenance="restore",
            actor=actor,
            restored_from=source.version,
            conditions=source.conditions,  # the same values, calibrated under the same conditions
        )
        life.changed(
            robot,
            AuditAction.VERSION_RESTORED,
            actor,
            version=new,
            details={"from_version": previous, "restored_from": source.version},
        )
        return version_out(repo.version(robot_id, new), new), etag(robot)


def import_version(
    *, db: Database, robot_id: str, body: ParameterVersionImport, actor: Actor, if_match: str | None
) -> tuple[ParameterVersionPublic, str]:
    """The parameters export (JSON or CSV) of this or another robot of the same model as a new current version."""
    with db.reader() as s:
        desc = description(Repository(s).robot(robot_id))
    # An export of a version calibrated with model terms names their parameters: the version carries them too.
    names = {p.name for p in body.parameters}
    terms = [t for t in ("thermal", "compliance") if any(n.startswith(t + ".") for n in names)]
    desc = requested_model(desc, terms) if terms else desc
    values, std, ident = import_in(desc, body)
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        robot = repo.robot(robot_id, lock=True)
        check_revision(robot, if_match)
        previous = robot.current_version
        new = life.add_version(
            robot, values=values, std_errors=std, identifiable=ident, provenance="import", actor=actor
        )
        life.changed(robot, AuditAction.VERSION_IMPORTED, actor, version=new, details={"from_version": previous})
        return version_out(repo.version(robot_id, new), new), etag(robot)
