from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from models import Registry, forward_kinematics
from models._types import Array
from models.cell import frame_layout, stage_frames
from models.compensation import inverse_kinematics
from models.compensation.terms import terms_inverse_kinematics
from models.description.terms import Conditions
from models.errors import InvalidInput
from models.identification.diagnosis import check_radians
from models.identification.pose_accuracy import MeasuredRegion, measured_region, pose_accuracy
from service.compute.model_cache import ModelCache
from service.conversions.calibrations import stored_prediction
from service.conversions.drift import condition_warnings
from service.conversions.kinematics import accuracy_out, forward_out, frames_out, inverse_out, joints_in, targets_in
from service.conversions.terms import request_conditions
from service.persistence import Repository
from service.persistence.lifecycle import Lifecycle
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse
from service.services.version_uncertainty import VersionUncertainty, calibrated_uncertainty


def forward(*, models: ModelCache, registry: Registry, robot_id: str, body: ForwardRequest) -> ForwardResponse:
    desc, theta = models.current(robot_id)
    joints = joints_in(desc, body.joints)
    # The pre-fit check that applies to joints alone: radians sent where degrees are expected still lie inside a
    # wide range and give poses, just the wrong ones.
    radians = check_radians(desc, joints)
    # The conditions count where the current version has model terms (a geometric version ignores them).
    conditions = request_conditions(joints.shape[0], body.temperature_c, body.payload)
    fk = forward_kinematics(
        desc, joints, theta, conditions=conditions if desc.terms.any else None, runtime=registry.runtime(desc)
    )
    frames = None
    if body.frames:
        # The frames the cell's shapes hang on, from the same Function its checks use: a drawing of the links
        # agrees with the verdicts shown beside it.
        found = stage_frames(desc, joints, theta, runtime=registry.runtime(desc))
        frames = frames_out(frame_layout(desc).names, found)
    out = forward_out(fk, [radians.message] if radians else [], frames)
    return _with_accuracy(out, models, registry, robot_id, joints) if body.accuracy else out


@dataclass(frozen=True)
class _Predictor:
    """The current version's covariance and its calibration's measured region, built once per version."""

    version: VersionUncertainty
    calibration_id: str
    free: NDArray[np.intp]
    covariance: Array
    region: MeasuredRegion


def _with_accuracy(
    out: ForwardResponse, models: ModelCache, registry: Registry, robot_id: str, joints: Array
) -> ForwardResponse:
    predictor = models.derived(robot_id, "accuracy", lambda _: _predictor(models, registry, robot_id))
    version = predictor.version
    found = pose_accuracy(
        version.desc,
        joints,
        version.values,
        predictor.free,
        predictor.covariance,
        region=predictor.region,
        runtime=registry.runtime(version.desc),
    )
    update = accuracy_out(found, predictor.region, predictor.calibration_id, version.number)
    return out.model_copy(update=update)


def _predictor(models: ModelCache, registry: Registry, robot_id: str) -> _Predictor:
    with models.db.reader() as s:
        repo = Repository(s)
        version = calibrated_uncertainty(repo, robot_id)
        if version is None or version.calibration_id is None:
            number = repo.version(robot_id).version
            raise InvalidInput(
                f"accuracy: version {number} of robot {robot_id!r} was not made by a calibration (it is the nominal, "
                "an imported or a restored version without one), so it has no covariance to predict from and no "
                "measured region: calibrate the robot first, or leave accuracy false",
                field="accuracy",
                reason="not_calibrated",
            )
        calibration = repo.calibration(version.calibration_id)
        records = Lifecycle(s).campaign(calibration.campaign_id).records
        stored = stored_prediction(calibration.result)
    measured = joints_in(version.desc, [r["joints"] for r in records if isinstance(r, dict) and "joints" in r])
    if stored is not None:
        names, covariance = stored
        free = np.array([version.desc.parameters.index[name] for name in names], dtype=np.intp)
    else:
        # A calibration stored before predictions were kept: its full covariance (it overstates a campaign in a
        # small region, where the unseen directions' variance is noise).
        free = version.estimated
        covariance = version.covariance[np.ix_(free, free)]
    region = measured_region(
        version.desc, measured, version.values, free, covariance, runtime=registry.runtime(version.desc)
    )
    return _Predictor(version, version.calibration_id, free, covariance, region)


def inverse(*, models: ModelCache, registry: Registry, robot_id: str, body: InverseRequest) -> InverseResponse:
    positions, quats = targets_in(body.targets)
    weights = np.asarray(body.weights, dtype=float) if body.weights is not None else None
    desc, theta = models.current(robot_id)
    seed = joints_in(desc, [body.seed])[0] if body.seed is not None else None
    conditions = request_conditions(positions.shape[0], body.temperature_c, body.payload)
    if desc.terms.any:
        answer = terms_inverse_kinematics(
            desc,
            positions,
            quats,
            theta,
            conditions=conditions or Conditions(),
            seed=seed,
            weights=weights,
            follow=body.follow,
            runtime=registry.runtime(desc),
            geometric_runtime=registry.runtime(desc.geometric),
        )
    else:
        answer = inverse_kinematics(
            desc,
            positions,
            quats,
            theta,
            seed=seed,
            weights=weights,
            follow=body.follow,
            runtime=registry.runtime(desc),
        )
    out = inverse_out(desc, answer)
    if conditions is None:
        return out
    version, calibrated = models.conditions(robot_id)
    warnings = condition_warnings(
        calibrated,
        version=version,
        temperatures=[] if conditions.temperature_c is None else conditions.temperature_c.tolist(),
        payloads_kg=[] if conditions.payload_kg is None else conditions.payload_kg.tolist(),
    )
    return out.model_copy(update={"warnings": warnings}) if warnings else out
