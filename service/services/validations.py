"""Validations: measurements that are never fitted, evaluated against parameter versions (ISO 9283 where they
repeat); and the ISO 9283 cube poses of a version. Read, compute outside any transaction, write in one."""

from __future__ import annotations

import numpy as np

from models import Registry
from models.errors import InvalidInput
from models.evaluation.accuracy import iso_cube_poses
from service.conversions.references import described
from service.conversions.robots import description
from service.conversions.terms import stored_model
from service.conversions.validations import iso_poses_out, validation_public, version_result_out
from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle
from service.schemas.validations import IsoPosesCreate, IsoPosesPublic, ValidationCreate, ValidationPublic
from service.services.pages import robot_page
from service.services.pipelines import fitting_in


def _checked_versions(repo: Repository, robot_id: str, wanted: list[int] | None) -> list[int]:
    if wanted is None:
        return [repo.current_version(robot_id)]
    latest = repo.latest_version(robot_id)
    for k, v in enumerate(wanted):
        if not 1 <= v <= latest:
            raise InvalidInput(
                f"versions[{k}]: version {v} does not exist; robot {robot_id!r} has versions 1 to {latest}",
                field=f"versions[{k}]",
            )
    if len(set(wanted)) != len(wanted):
        raise InvalidInput("versions: each version at most once", field="versions")
    return list(wanted)


def validate(*, db: Database, registry: Registry, robot_id: str, body: ValidationCreate) -> ValidationPublic:
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        versions = _checked_versions(repo, robot_id, body.versions)
        values = {v: np.asarray(repo.version(robot_id, v).values, dtype=float) for v in versions}
    # Each version on its own model: one calibrated with model terms evaluates them at the records' conditions.
    models = {v: stored_model(desc, values[v].size) for v in versions}
    fitting = fitting_in(desc, body.measurements, described(body), sigma_mm=None)
    reports = {
        v: fitting.evaluate(v, models[v], values[v], register=body.fit_frame, runtime=registry.runtime(models[v]))
        for v in versions
    }
    results = [version_result_out(models[v], v, reports[v]).model_dump(mode="json") for v in versions]
    document = {
        "measurement": fitting.kind.value,
        "measurements": fitting.size,
        "results": results,
        "import_notes": body.import_notes,
    }
    records = [r.model_dump() for r in body.measurements]
    instrument = None if body.instrument is None else body.instrument.model_dump()
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        repo.robot(robot_id, lock=True)  # still there
        stored = repo.add_campaign(robot_id, records)
        return validation_public(life.add_validation(robot_id, stored.id, document, body.notes, instrument))


def get_validation(*, db: Database, validation_id: str) -> ValidationPublic:
    with db.reader() as s:
        return validation_public(Lifecycle(s).validation(validation_id))


def list_validations(*, db: Database, robot_id: str, limit: int, offset: int) -> list[ValidationPublic]:
    return robot_page(db, robot_id, Lifecycle.validations, validation_public, limit=limit, offset=offset)


def iso_poses(*, db: Database, registry: Registry, robot_id: str, body: IsoPosesCreate) -> IsoPosesPublic:
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        version = repo.current_version(robot_id) if body.version is None else body.version
        latest = repo.latest_version(robot_id)
        if version > latest:
            raise InvalidInput(
                f"version {version} does not exist; robot {robot_id!r} has versions 1 to {latest}", field="version"
            )
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
    # The cube's commands from the geometry (at the reference conditions of a version with model terms).
    geometry = values[: desc.n_params]
    return iso_poses_out(
        desc, robot_id, version, iso_cube_poses(desc, geometry, seed=body.seed, runtime=registry.runtime(desc))
    )
