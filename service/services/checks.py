"""Quick checks: a few tracker records against the current version (models.evaluation.checks), their design, and a
robot's
history of calibrations and checks. Read, compute outside any transaction, write in one."""

from __future__ import annotations

from models import NoiseModel, Registry
from models.errors import InvalidInput
from models.evaluation.checks import CheckOptions
from models.measurement import MeasurementKind
from optimal_design.checks import design_check
from service.conversions.checks import check_design_out, check_document, check_public, history_out
from service.conversions.drift import condition_warnings
from service.conversions.references import described
from service.conversions.units import instrument_noise
from service.persistence import Database, Repository
from service.persistence.lifecycle import Lifecycle
from service.schemas.calibrations import Noise
from service.schemas.checks import (
    Against,
    HistoryEventPublic,
    QuickCheckCreate,
    QuickCheckDesignCreate,
    QuickCheckDesignPublic,
    QuickCheckPublic,
)
from service.services.pages import robot_page
from service.services.pipelines import fitting_in
from service.services.version_uncertainty import VersionUncertainty, calibrated_uncertainty, nominal_uncertainty

HISTORY_MAX = 10_000


def _current(repo: Repository, robot_id: str, against: Against) -> VersionUncertainty:
    if against == "tolerances":
        return nominal_uncertainty(repo, robot_id)
    found = calibrated_uncertainty(repo, robot_id)
    if found is None:
        version = repo.version(robot_id).version
        raise InvalidInput(
            f"version {version} of robot {robot_id!r} carries no calibrated uncertainty (it is the nominal or an "
            "imported version): calibrate the robot first, or check against its nominal tolerances "
            '("against": "tolerances")',
            field="against",
            reason="not_calibrated",
        )
    return found


def _noise(noise: Noise) -> NoiseModel:
    return instrument_noise(noise.position_mm, noise.orientation_deg)


def create_check(*, db: Database, registry: Registry, robot_id: str, body: QuickCheckCreate) -> QuickCheckPublic:
    with db.reader() as s:
        current = _current(Repository(s), robot_id, body.against)
    desc = current.desc
    options = CheckOptions(
        alpha=body.alpha,
        register=body.fit_frame,
        change_sigmas=body.change_sigmas,
        drift_ratio=body.drift_ratio,
        calibration_poses=current.calibration_poses,
    )
    noise, runtime = _noise(body.noise), registry.runtime(desc)
    fitting = fitting_in(desc, body.measurements, described(body), sigma_mm=body.noise.position_mm)
    result = fitting.check(desc, current.values, current.covariance, noise=noise, options=options, runtime=runtime)
    document = check_document(desc, current.number, body.against, result, kind=fitting.kind, size=fitting.size)
    # The check is answered all the same; a version calibrated under other conditions is said to be (the
    # records that state a temperature or a payload: a tracker's).
    warnings = condition_warnings(
        current.conditions,
        version=current.number,
        temperatures=[t for r in body.measurements if (t := getattr(r, "temperature_c", None)) is not None],
        payloads_kg=[p.mass_kg for r in body.measurements if (p := getattr(r, "payload", None)) is not None],
    )
    document["warnings"] = [w.model_dump(mode="json") for w in warnings]
    document["import_notes"] = body.import_notes
    with db.session() as s:
        repo, life = Repository(s), Lifecycle(s)
        repo.robot(robot_id, lock=True)  # still there
        stored = repo.add_campaign(robot_id, [r.model_dump() for r in body.measurements])
        record = life.add_check(robot_id, stored.id, current.number, result.verdict.value, document)
        record.notes = body.notes
        record.instrument = None if body.instrument is None else body.instrument.model_dump()
        return check_public(record)


def design_check_poses(
    *, db: Database, registry: Registry, robot_id: str, body: QuickCheckDesignCreate
) -> QuickCheckDesignPublic:
    """Poses for a check of the current version; stores nothing (the seed repeats it)."""
    with db.reader() as s:
        current = _current(Repository(s), robot_id, body.against)
    desc = current.desc
    position_only = MeasurementKind(body.measurement).position_only
    options = CheckOptions(alpha=body.alpha, register=body.fit_frame)
    design = design_check(
        desc,
        current.values,
        body.count,
        covariance=current.covariance,
        watched=None if body.watch is None else desc.parameters.indices(body.watch),
        position_only=position_only,
        candidate_count=body.candidate_count,
        seed=body.seed,
        noise=_noise(body.noise),
        options=options,
        runtime=registry.runtime(desc),
    )
    return check_design_out(
        desc, robot_id, current.number, design, position_only=position_only, registered=body.fit_frame
    )


def get_check(*, db: Database, check_id: str) -> QuickCheckPublic:
    with db.reader() as s:
        return check_public(Lifecycle(s).check(check_id))


def list_checks(*, db: Database, robot_id: str, limit: int, offset: int) -> list[QuickCheckPublic]:
    return robot_page(db, robot_id, Lifecycle.checks, check_public, limit=limit, offset=offset)


def history(*, db: Database, robot_id: str, limit: int, offset: int) -> list[HistoryEventPublic]:
    """The first `offset + limit` of each kind are enough for that page of the merged timeline."""
    with db.reader() as s:
        repo = Repository(s)
        wanted = min(offset + limit, HISTORY_MAX)
        events = history_out(repo.calibrations(robot_id, wanted, 0), Lifecycle(s).checks(robot_id, wanted, 0))
    return events[offset : offset + limit]
