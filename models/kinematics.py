"""Numeric kinematics on batches of joint vectors: validation, FK, Jacobians.

Everything here is in internal units (mm, rad) and works on arrays of shape
(N, n_joints). Each call validates its input and raises a domain error naming
the pose, the joint, the value and the limit; the compiled Functions are
those of the structure's runtime (`models.engine.runtime`), never rebuilt.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array
from models.description.parameters import Kind
from models.description.robot import RobotDescription
from models.description.terms import Conditions, condition_inputs
from models.engine.runtime import Runtime, runtime_for
from models.errors import JointOutOfRange, NonFiniteValue, UnreachablePose, WrongShape

JOINT_RANGE_SLACK = 1e-9
"""Joints may exceed their range by this much (mm or rad) before they are rejected: float round-off."""
MEASURED_OVERSHOOT = 0.01
"""A measured joint reading may pass its range by this share of the span (1 %: 3.5 mm of TIAGo's 350 mm torso,
1.6° of a 157° joint). A URDF's limits are the controller's command limits, and a reading at the stop can pass
them: TIAGo's torso read 350.18 mm against its URDF's 350 in a real campaign, which was refused whole. Beyond
this a reading is a slip (units, another robot's file) and is still refused with its pose and joint."""
CLOSURE_TOLERANCE_MM = 1e-8
"""A hexapod pose counts as assembled when every leg equation holds to this (mm)."""
ENVELOPE_MARGIN_MM = 20.0
ENVELOPE_MARGIN_RAD = float(np.radians(5.0))
"""How far outside the workspace box the FK may land before the legs are rejected as not assembling
(Newton can converge to a mirror assembly far from the working one)."""
MAX_NEWTON_CALLS = 5


def as_joint_array(desc: RobotDescription, joints: ArrayLike) -> Array:
    """Joint vectors as an (N, n_joints) float array; shape and finiteness checked."""
    return joint_vectors(joints, desc.joint_names)


def joint_vectors(joints: ArrayLike, names: Sequence[str], *, of: str = "") -> Array:
    """Joint vectors as an (N, len(names)) float array (one vector: N = 1), a refusal naming the pose and the joint
    (`names`) for the wrong shape or a number that is not finite: a robot's (`of` empty) and a tree's (`of` " of
    the tree", which the shape's refusal says) alike."""
    try:
        arr = np.array(joints, dtype=float)
    except (TypeError, ValueError) as exc:
        raise WrongShape(f"joint vectors must be numbers: {exc}", field="joints") from exc
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != len(names):
        raise WrongShape(
            f"each joint vector{of} must have {len(names)} numbers {list(names)}, got shape {arr.shape}",
            field="joints",
            expected=[-1, len(names)],
            got=list(arr.shape),
        )
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        i, j = (int(v) for v in bad[0])
        raise NonFiniteValue(f"pose {i}: joint {names[j]} is {arr[i, j]}, not a finite number", pose=i, joint=names[j])
    return arr


def check_joint_ranges(desc: RobotDescription, joints: Array, *, measured: bool = False) -> None:
    """Raise JointOutOfRange for the first joint outside its range (internal units). `measured`: the joints are
    readings of where the robot was (a campaign's records), which may pass the description's limits by
    MEASURED_OVERSHOOT of the span; commands (targets, designs, compensation) may not."""
    span = desc.joint_max - desc.joint_min
    slack = (
        np.maximum(JOINT_RANGE_SLACK, MEASURED_OVERSHOOT * span) if measured else np.full_like(span, JOINT_RANGE_SLACK)
    )
    refuse_out_of_range(
        joints, desc.joint_min, desc.joint_max, slack=slack, names=desc.joint_names, kinds=desc.joint_kinds
    )


def refuse_out_of_range(
    joints: Array,
    low: Array,
    high: Array,
    *,
    slack: Array | float,
    names: Sequence[str],
    kinds: Sequence[Kind],
) -> None:
    """Raise JointOutOfRange for the first joint of `joints` (N, n) outside [low − slack, high + slack], internal
    units, named by `names` and told in its kind's boundary unit with the limits as given (without the slack):
    the refusal of a robot's joints and a tree's alike."""
    bad = np.argwhere((joints < low - slack) | (joints > high + slack))
    if bad.size:
        i, j = (int(v) for v in bad[0])
        scale, unit = kinds[j].to_boundary, kinds[j].boundary_unit
        value, lo, hi = joints[i, j] * scale, low[j] * scale, high[j] * scale
        raise JointOutOfRange(
            f"pose {i}: joint {names[j]} = {value:.6g} {unit} is outside its range [{lo:.6g}, {hi:.6g}] {unit}",
            pose=i,
            joint=names[j],
            value=float(value),
            min=float(lo),
            max=float(hi),
            unit=unit,
            count=len(np.unique(bad[:, 0])),
        )


def solve_platforms(
    desc: RobotDescription,
    joints: Array,
    params: ArrayLike,
    seeds: Array | None = None,
    *,
    runtime: Runtime | None = None,
    conditions: Array | None = None,
) -> tuple[Array, Array]:
    """Hexapod forward kinematics for a batch: platform poses (N, 6) and closure error (N,) in mm.

    Newton from the home pose (or the given seeds), all poses at once; poses not
    yet converged get more steps. Nothing is checked here: see `forward_kinematics`. `conditions` (N, 7):
    the inputs of a structure with model terms (`models.description.terms.condition_inputs`); None: reference
    conditions.
    """
    fns = runtime_for(desc, runtime).kinematics
    n = joints.shape[0]
    theta = np.asarray(params, dtype=float)
    x = np.tile(np.asarray(desc.platform_home, dtype=float), (n, 1)) if seeds is None else np.array(seeds, dtype=float)
    if not desc.has_closure:
        # No platform to solve: the graphs ignore it (see `models.engine.symbolic`).
        return np.zeros((n, desc.n_platform)), np.zeros(n)
    todo = np.arange(n)
    closure = np.full(n, np.inf)
    for _ in range(MAX_NEWTON_CALLS):
        cond = None if conditions is None else conditions[todo]
        x_new, res = fns.batch("newton_solve", joints[todo], theta, x[todo], conditions=cond)
        x[todo] = x_new
        closure[todo] = res[:, 0]
        todo = todo[~(closure[todo] <= CLOSURE_TOLERANCE_MM)]
        if todo.size == 0:
            break
    return x, closure


def hexapod_condition(desc: RobotDescription, platforms: Array, params: ArrayLike) -> Array:
    """Condition number of the hexapod Jacobian (eq. 48), rotations scaled by the platform radius: unit-free,
    without bound near a singularity; the worst parallel stage's where there are several (NaN without one).
    """
    if not desc.has_closure:
        return np.full(platforms.shape[0], np.nan)  # no parallel stage: no condition of one
    theta = np.asarray(params, dtype=float)
    per_stage = [
        desc.stages[k].conditioning(platforms[:, desc.placements[k].unknowns], theta[desc.placements[k].params])
        for k in desc.closed_stages
    ]
    return np.asarray(np.max(per_stage, axis=0), dtype=float)


def platform_envelope(desc: RobotDescription) -> tuple[Array, Array]:
    """(lo, hi) of the closures' unknowns with a margin: beyond it an assembly is another (a mirror) one."""
    assert desc.has_closure, "only a parallel stage has a platform envelope"
    lo, hi = desc.platform_limits
    margin = np.tile([ENVELOPE_MARGIN_MM] * 3 + [ENVELOPE_MARGIN_RAD] * 3, lo.size // 6)
    return lo - margin, hi + margin


def check_assembly(desc: RobotDescription, platforms: Array, closure: Array, params: ArrayLike) -> None:
    """UnreachablePose for the first pose whose legs do not assemble into a usable pose of every parallel
    stage."""
    if not desc.has_closure:
        return
    _refuse_first(
        ~(closure <= CLOSURE_TOLERANCE_MM),
        "no_assembly",
        lambda i: (
            "the hexapod cannot assemble with these leg lengths (forward kinematics did not converge; "
            f"leg equations off by {closure[i]:.3g} mm)"
        ),
    )
    low, high = platform_envelope(desc)
    _refuse_first(
        np.any((platforms < low) | (platforms > high), axis=1),
        "outside_workspace",
        lambda i: (
            f"the leg lengths put the platform at "
            f"{np.round(np.r_[platforms[i, :3], np.degrees(platforms[i, 3:6])], 3).tolist()} (mm, deg), "
            "outside the hexapod's workspace"
        ),
    )
    cond = hexapod_condition(desc, platforms, params)
    limit = min(desc.stages[k].max_condition for k in desc.closed_stages)
    _refuse_first(
        cond > limit,
        "near_singularity",
        lambda i: f"the hexapod is too close to a singularity (condition number {cond[i]:.3g} > {limit:.3g})",
    )


def _refuse_first(failed: NDArray[np.bool_], reason: str, message: Callable[[int], str]) -> None:
    """UnreachablePose naming the first failed pose (and how many failed) for `reason`."""
    index = np.flatnonzero(failed)
    if index.size:
        i = int(index[0])
        raise UnreachablePose(f"pose {i}: {message(i)}", pose=i, reason=reason, count=int(index.size))


@dataclass(frozen=True)
class ForwardResult:
    positions: Array
    """(N, 3) mm, world frame."""
    rotations: Array
    """(N, 3, 3) TCP orientation in the world frame."""
    platforms: Array
    """(N, 6) hexapod platform poses (mm, rad)."""


@dataclass(frozen=True)
class ForwardJacobianResult(ForwardResult):
    """Forward kinematics with the identification Jacobians (`jacobian=True`)."""

    jacobians: Array
    """(N, 6, n_params) identification Jacobians (rows dp, dω)."""


@overload
def forward_kinematics(
    desc: RobotDescription,
    joints: ArrayLike,
    params: ArrayLike | None = None,
    *,
    jacobian: Literal[False] = False,
    check_ranges: bool = True,
    seeds: Array | None = None,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
) -> ForwardResult: ...


@overload
def forward_kinematics(
    desc: RobotDescription,
    joints: ArrayLike,
    params: ArrayLike | None = None,
    *,
    jacobian: Literal[True],
    check_ranges: bool = True,
    seeds: Array | None = None,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
) -> ForwardJacobianResult: ...


def forward_kinematics(
    desc: RobotDescription,
    joints: ArrayLike,
    params: ArrayLike | None = None,
    *,
    jacobian: bool = False,
    check_ranges: bool = True,
    seeds: Array | None = None,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
) -> ForwardResult:
    """TCP poses (and optionally identification Jacobians) for a batch of joint vectors.

    With model terms on (`desc.terms`), `conditions` says what each joint vector runs under (a temperature for
    the thermal term, a payload for the compliance term; InvalidInput names what a term needs and they lack);
    None: the reference conditions (T_ref, no payload).
    """
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    q = as_joint_array(desc, joints)
    if check_ranges:
        check_joint_ranges(desc, q)
    cond = condition_inputs(desc.terms, conditions, q.shape[0]) if desc.terms.any and conditions else None
    platforms, closure = solve_platforms(desc, q, theta, seeds, runtime=rt, conditions=cond)
    check_assembly(desc, platforms, closure, theta)
    if jacobian:
        return pose_jacobian_batch(desc, q, theta, platforms, runtime=rt, conditions=cond)
    return pose_batch(desc, q, theta, platforms, runtime=rt, conditions=cond)


def pose_batch(
    desc: RobotDescription,
    q: Array,
    theta: Array,
    platforms: Array,
    *,
    runtime: Runtime | None = None,
    conditions: Array | None = None,
) -> ForwardResult:
    """TCP poses for already solved platform poses; no checks."""
    pos, rot = runtime_for(desc, runtime).kinematics.batch("pose_at", q, theta, platforms, conditions=conditions)
    return ForwardResult(pos, rot, platforms)


def pose_jacobian_batch(
    desc: RobotDescription,
    q: Array,
    theta: Array,
    platforms: Array,
    *,
    runtime: Runtime | None = None,
    conditions: Array | None = None,
) -> ForwardJacobianResult:
    """TCP poses and identification Jacobians for already solved platform poses; no checks."""
    fns = runtime_for(desc, runtime).kinematics
    pos, rot, jac = fns.batch("pose_jacobian_at", q, theta, platforms, conditions=conditions)
    return ForwardJacobianResult(pos, rot, platforms, jac)


def inverse_hexapod(
    desc: RobotDescription, platforms: ArrayLike, params: ArrayLike | None = None, *, runtime: Runtime | None = None
) -> Array:
    """Closed-form hexapod IK: commanded leg lengths (N, 6) for platform poses (N, 6)."""
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    x = np.atleast_2d(np.asarray(platforms, dtype=float))
    (legs,) = runtime_for(desc, runtime).kinematics.batch("hexapod_ik", x, theta[desc.slices["hexapod"]])
    return legs


def leg_tensions(
    desc: RobotDescription,
    q: Array,
    theta: Array,
    platforms: Array,
    *,
    force_world: Array,
    cog_mm: Array,
    runtime: Runtime | None = None,
    conditions: Array | None = None,
) -> Array:
    """(N, 6) leg tensions (N) that carry a payload: its gravity force `force_world` (N, 3; world frame) at its
    centre of gravity `cog_mm` (N, 3; tool frame), by the hexapod's statics t = J⁻ᵀ w (thesis eq. 48; `w` the
    force and its moment about the platform origin, in {4}). Numeric twin of `models.engine.symbolic.terms_closure`'s
    statics, for a description with or without terms (`conditions`: its terms' inputs)."""
    assert desc.hexapod is not None, "only a hexapod has legs to carry a load"
    fns = runtime_for(desc, runtime).kinematics
    (carriage,) = fns.batch("carriage_fk", q[:, : desc.n_chain], theta, conditions=conditions)
    pos, rot = fns.batch("pose_at", q, theta, platforms, conditions=conditions)
    (jhex,) = fns.batch("hexapod_jacobian", platforms, theta[desc.slices["hexapod"]])
    r4, o4 = carriage[:, :3, :3], carriage[:, :3, 3]
    cog_world = np.einsum("nij,nj->ni", rot, cog_mm) + pos
    origin_world = np.einsum("nij,nj->ni", r4, platforms[:, :3]) + o4
    force = np.einsum("nji,nj->ni", r4, force_world)
    arm = np.einsum("nji,nj->ni", r4, cog_world - origin_world)
    wrench = np.concatenate([force, np.cross(arm, force)], axis=1)
    return np.asarray(np.linalg.solve(np.transpose(jhex, (0, 2, 1)), wrench[:, :, None])[:, :, 0])
