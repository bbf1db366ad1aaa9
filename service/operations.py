"""What the routes and the job workers do: read, compute (no transaction open), then write in one transaction.

Domain errors raised while computing leave the database untouched; a calibration and its new parameter
version are written together, and only when the identification succeeded.
"""

from __future__ import annotations

import math
import threading
from collections import OrderedDict
from typing import Any

import numpy as np

from models import RobotDescription, iwr
from models.campaign import make_campaign
from models.errors import InvalidInput
from models.hybrid import Pose6
from models.identifiability import NoiseModel
from models.identification import IdentificationOptions, RobustLoss, identify
from optimal_design import design_poses
from service.conversions import joints_in, pose6_in, pose6_out, unit_quaternion
from service.errors import BadRequest
from service.persistence import Database, Repository
from service.persistence.repository import new_id
from service.persistence.tables import CalibrationRecord, ParameterVersion, PoseDesignRecord, Robot
from service.schemas.calibrations import CalibrationCreate
from service.schemas.designs import PoseDesignCreate
from service.schemas.robots import RobotCreate


def description(robot: Robot) -> RobotDescription:
    b, t = (float(v) for v in robot.base), (float(v) for v in robot.tool)
    base: Pose6 = (next(b), next(b), next(b), next(b), next(b), next(b))
    tool: Pose6 = (next(t), next(t), next(t), next(t), next(t), next(t))
    return iwr(base, tool)


def strict_json(value: Any) -> Any:
    """NaN and infinities as null: JSON (and PostgreSQL's JSON type) has no such numbers."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [strict_json(v) for v in value]
    return value


def create_robot(db: Database, body: RobotCreate) -> Robot:
    base = pose6_in(body.base.position, body.base.orientation, "base") if body.base else pose6_in(None, None, "base")
    tool = pose6_in(body.tool.position, body.tool.orientation, "tool") if body.tool else pose6_in(None, None, "tool")
    desc = iwr(base, tool)
    with db.session() as s:
        return Repository(s).add_robot(body.name, body.model, list(base), list(tool), desc.parameters.nominal.tolist())


def robot_public(robot: Robot) -> dict[str, Any]:
    return {
        "id": robot.id,
        "name": robot.name,
        "model": robot.model,
        "parameter_version": robot.current_version,
        "created_at": robot.created_at,
        "base": pose6_out(robot.base),
        "tool": pose6_out(robot.tool),
    }


def parameters_public(desc: RobotDescription, version: ParameterVersion) -> dict[str, Any]:
    table = desc.parameters
    values = table.as_boundary(np.asarray(version.values, dtype=float))
    nominal = table.as_boundary(table.nominal)
    std = version.std_errors or [None] * len(table)
    ident = version.identifiable or [None] * len(table)
    return {
        "version": version.version,
        "provenance": version.provenance,
        "calibration_id": version.calibration_id,
        "parameters": [
            {
                "name": name,
                "value": float(values[i]),
                "unit": table.units[i],
                "nominal": float(nominal[i]),
                "std_error": None if std[i] is None else float(std[i]) * float(table.to_boundary[i]),
                "identifiable": ident[i],
            }
            for i, name in enumerate(table.names)
        ],
    }


_MODELS: OrderedDict[tuple[str, str, int], tuple[RobotDescription, np.ndarray]] = OrderedDict()
_MODELS_LOCK = threading.Lock()


def current_model(db: Database, robot_id: str) -> tuple[RobotDescription, np.ndarray]:
    """The robot's description and current parameters; parameter versions are immutable, so one small query for
    the current version number is all a request needs once the version has been seen."""
    version = db.current_version(robot_id)
    if version is not None:
        with _MODELS_LOCK:
            found = _MODELS.get((db.url, robot_id, version))
        if found is not None:
            return found
    with db.reader() as s:
        repo = Repository(s)
        version = repo.current_version(robot_id)
        key = (db.url, robot_id, version)
        robot = repo.robot(robot_id)
        values = np.asarray(repo.version(robot_id, version).values, dtype=float)
    model = (description(robot), values)
    with _MODELS_LOCK:
        _MODELS[key] = model
        while len(_MODELS) > 256:
            _MODELS.popitem(last=False)
    return model


def calibration_public(record: CalibrationRecord, *, json_ready: bool = False) -> dict[str, Any]:
    return {
        **record.result,
        "id": record.id,
        "robot_id": record.robot_id,
        "campaign_id": record.campaign_id,
        "status": record.status,
        "applied": record.applied,
        "parameter_version": record.parameter_version,
        "start_version": record.start_version,
        "created_at": record.created_at.isoformat() if json_ready else record.created_at,
    }


def calibrate(db: Database, robot_id: str, body: CalibrationCreate) -> CalibrationRecord:
    with db.reader() as s:
        repo = Repository(s)
        desc = description(repo.robot(robot_id))
        start_row = _start_version(repo, robot_id, body.start_version)
        start_version = start_row.version
        start_values = np.asarray(start_row.values, dtype=float)
        start_std = list(start_row.std_errors or [None] * len(start_values))
        start_ident = list(start_row.identifiable or [False] * len(start_values))
    records = [r.model_dump() for r in body.measurements]
    with_orientation = [r.orientation is not None for r in body.measurements]
    if any(with_orientation) and not all(with_orientation):
        first = with_orientation.index(not with_orientation[0])
        raise BadRequest(
            f"record {first}: either every record has an orientation or none has (position-only campaign)",
            record=first,
        )
    joints = joints_in(desc, [r.joints for r in body.measurements])
    positions = np.array([r.position for r in body.measurements], dtype=float)
    quats = np.array([r.orientation for r in body.measurements], dtype=float) if all(with_orientation) else None
    campaign = make_campaign(desc, joints, positions, quats)
    noise = NoiseModel(body.noise.position_mm, math.radians(body.noise.orientation_deg))
    options = IdentificationOptions(
        estimate=tuple(body.options.estimate),
        robust=RobustLoss(body.options.robust),
        robust_scale=body.options.robust_scale,
    )
    # The fit starts from the chosen version, so whatever it does not estimate keeps that version's calibrated
    # values (a base-only re-fit after the tracker moved must not send the links and legs back to nominal).
    result = identify(desc, campaign, noise=noise, nominal=start_values, options=options)
    payload = strict_json(result.to_dict())
    nominal = desc.parameters.as_boundary(desc.parameters.nominal)
    start = desc.parameters.as_boundary(start_values)
    for i, entry in enumerate(payload["parameters"]):
        entry["nominal"], entry["start"] = float(nominal[i]), float(start[i])
    payload["start_version"] = start_version
    calibration_id = new_id()
    with db.session() as s:
        repo = Repository(s)
        robot = repo.robot(robot_id, lock=True)  # still there, and one calibration at a time per robot
        stored = repo.add_campaign(robot_id, records)
        record = repo.add_calibration(calibration_id, robot_id, stored.id, result.status, payload)
        record.start_version = start_version
        if result.succeeded and body.apply:
            # What this fit estimated carries its new statistics; the rest keeps the start version's.
            std, ident = start_std, start_ident
            for i in result.estimated:
                value = float(result.std_errors[i])
                std[i], ident[i] = (value if np.isfinite(value) else None), True
            record.parameter_version = repo.add_version(robot, result.parameters.tolist(), std, ident, calibration_id)
            record.applied = True
        return record


def _start_version(repo: Repository, robot_id: str, version: int | None) -> ParameterVersion:
    if version is None:
        return repo.version(robot_id)
    latest = repo.latest_version(robot_id)
    if version > latest:
        raise InvalidInput(
            f"start_version {version} does not exist: robot {robot_id!r} has versions 1 to {latest}",
            field="start_version",
        )
    return repo.version(robot_id, version)


def design(db: Database, robot_id: str, body: PoseDesignCreate) -> PoseDesignRecord:
    desc, theta = current_model(db, robot_id)
    candidates = joints_in(desc, body.candidates) if body.candidates is not None else None
    fixed = joints_in(desc, body.fixed) if body.fixed is not None else None
    result = design_poses(
        desc,
        body.count,
        body.criterion,
        body.measurement,
        candidates=candidates,
        candidate_count=body.candidate_count,
        seed=body.seed,
        fixed=fixed,
        params=theta,
    )
    payload = strict_json(result.to_dict(desc, include_indices=candidates is not None))
    if candidates is None:
        payload["indices"] = None
    with db.session() as s:
        repo = Repository(s)
        repo.robot(robot_id)
        return repo.add_design(robot_id, body.model_dump(), payload)


def design_public(record: PoseDesignRecord) -> dict[str, Any]:
    return {**record.result, "id": record.id, "robot_id": record.robot_id, "created_at": record.created_at}


def targets_in(targets: list[Any]) -> tuple[np.ndarray, np.ndarray | None]:
    with_orientation = [t.orientation is not None for t in targets]
    if any(with_orientation) and not all(with_orientation):
        first = with_orientation.index(not with_orientation[0])
        raise BadRequest(f"target {first}: give an orientation for every target or for none (position only)")
    positions = np.array([t.position for t in targets], dtype=float)
    if not all(with_orientation):
        return positions, None
    quats = np.array([t.orientation for t in targets], dtype=float)
    return positions, quats


__all__ = ["unit_quaternion"]
