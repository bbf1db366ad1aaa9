from __future__ import annotations

import numpy as np

from models import Registry, forward_kinematics
from models.cell import frame_layout, stage_frames
from models.compensation import inverse_kinematics
from models.compensation.terms import terms_inverse_kinematics
from models.description.terms import Conditions
from models.identification.diagnosis import check_radians
from service.compute.model_cache import ModelCache
from service.conversions.drift import condition_warnings
from service.conversions.kinematics import forward_out, frames_out, inverse_out, joints_in, targets_in
from service.conversions.terms import request_conditions
from service.schemas.kinematics import ForwardRequest, ForwardResponse, InverseRequest, InverseResponse


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
    return forward_out(fk, [radians.message] if radians else [], frames)


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
