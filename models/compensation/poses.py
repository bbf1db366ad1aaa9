"""Compensated Cartesian targets: the pose to give a controller that runs the nominal model so that the calibrated
robot's TCP lands where the nominal robot's would have.

For a target T (robot-base frame, mm) the nominal controller would drive the joints q_nom = IK_nominal(T). The
calibrated robot reaches T at q* = IK_calibrated(T), seeded at q_nom (the same configuration, the nearest
solution). Commanding T' = FK_nominal(q*) makes the nominal controller drive q*, which the real robot turns into
T. The robot-base frame is the calibrated model's base frame, as in `correct_program`: the nominal promise is
the nominal geometry placed where the calibrated model puts the robot's base.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models._types import Array
from models.compensation.compensate import compensate
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.inverse import default_seed, inverse_kinematics
from models.inverse.problem import joint_weights
from models.inverse.routing import IkBatch
from models.kinematics import forward_kinematics
from models.transforms import matrix_to_quaternion, matrix_to_rotvec_np, rotvec_to_matrix_np

FAR_MM = 1.0e5
"""100 m from the base: beyond any arm's reach (the largest industrial arms reach under 5 m)."""
MAX_BRANCH_STEP_RAD = float(np.radians(5.0))
"""A compensation moves joints by hundredths of a degree; a joint of q* more than this away from q_nom means
the calibrated solution lies on another branch (a wrist flip, a turn), which the controller would not follow."""


@dataclass(frozen=True)
class PoseCompensation:
    """Corrected targets, with the joints behind them and a reason for every target left as it was."""

    poses: Array
    """(N, 4, 4) corrected targets in the robot-base frame (mm); the original where not reached."""
    reached: NDArray[np.bool_]
    reasons: tuple[str | None, ...]
    nominal_joints: Array
    """(N, n_joints) the nominal controller's joints for the original target (NaN where it has none)."""
    joints: Array
    """(N, n_joints) the calibrated robot's joints reaching the original target (NaN where none)."""


def pose_matrices(positions: ArrayLike, rotations: ArrayLike) -> Array:
    """(N, 4, 4) homogeneous transforms from (N, 3) positions and (N, 3, 3) rotations."""
    p = np.asarray(positions, dtype=float)
    out = np.tile(np.eye(4), (p.shape[0], 1, 1))
    out[:, :3, :3] = np.asarray(rotations, dtype=float)
    out[:, :3, 3] = p
    return out


def pose6_matrix(pose6: ArrayLike) -> Array:
    """4x4 of a (translation mm, rotation vector rad) 6-vector, the parameters' convention for base and tool."""
    v = np.asarray(pose6, dtype=float)
    out: Array = pose_matrices(v[None, :3], rotvec_to_matrix_np(v[None, 3:6]))[0]
    return out


def matrix_pose6(t: Array) -> Array:
    out: Array = np.r_[t[:3, 3], matrix_to_rotvec_np(t[:3, :3])]
    return out


def compensate_poses(
    desc: RobotDescription,
    calibrated: ArrayLike,
    nominal: ArrayLike,
    targets: ArrayLike,
    *,
    tools: Sequence[ArrayLike | None] | None = None,
    seeds: ArrayLike | None = None,
    runtime: Runtime | None = None,
    deadline: float | None = None,
) -> PoseCompensation:
    """Targets (N, 4, 4, robot-base frame, mm) corrected for the calibrated robot, run by a nominal controller.

    `tools`: per target, the flange -> TCP transform (4x4) it is taught with (a program's tool), replacing the
    models' own tool in both models; None (for all, or for one target): each model keeps its own tool, the
    calibrated one as measured, the nominal one as designed. `seeds`: joints near which the nominal
    controller's solution is sought (one vector or one per target; default the model's default seed).
    Targets are solved in one batch per distinct tool. `deadline` (a `time.monotonic()` instant): the targets
    that Newton from their seed leaves to the general inverse kinematics (about 0.3 s of CPU each: table starts,
    multistart, IPOPT) are not started after it and keep a reason, so a request answers in its time.
    """
    rt = runtime_for(desc, runtime)
    theta_cal = desc.parameters.vector(calibrated)
    theta_nom = desc.parameters.vector(nominal).copy()
    theta_nom[desc.slices["base"]] = theta_cal[desc.slices["base"]]
    t = np.asarray(targets, dtype=float).reshape(-1, 4, 4)
    n = t.shape[0]
    seed_rows = None if seeds is None else np.broadcast_to(np.asarray(seeds, dtype=float), (n, desc.n_joints))
    base = pose6_matrix(theta_cal[desc.slices["base"]])
    world = base @ t
    out = PoseCompensation(
        poses=t.copy(),
        reached=np.zeros(n, dtype=bool),
        reasons=tuple([None] * n),
        nominal_joints=np.full((n, desc.n_joints), np.nan),
        joints=np.full((n, desc.n_joints), np.nan),
    )
    reasons: list[str | None] = list(out.reasons)
    solvable = _screened(t, reasons)
    for tool, group in _tool_groups(tools, n):
        idx = group[solvable[group]]
        if idx.size == 0:
            continue
        cal, nom = theta_cal.copy(), theta_nom.copy()
        if tool is not None:
            cal[desc.slices["tool"]] = nom[desc.slices["tool"]] = tool
        seed = None if seed_rows is None else seed_rows[idx]
        corrected, q_nom, q_cal, why = _compensate_group(
            desc, cal, nom, world[idx], seed=seed, rt=rt, deadline=deadline
        )
        out.poses[idx] = np.linalg.inv(base) @ corrected
        out.nominal_joints[idx], out.joints[idx] = q_nom, q_cal
        out.reached[idx] = [w is None for w in why]
        for k, i in enumerate(idx):
            reasons[i] = why[k]
    return PoseCompensation(out.poses, out.reached, tuple(reasons), out.nominal_joints, out.joints)


def compensate_near(
    desc: RobotDescription,
    calibrated: ArrayLike,
    world: ArrayLike,
    seeds: ArrayLike,
    *,
    runtime: Runtime | None = None,
) -> tuple[Array, NDArray[np.bool_], tuple[str | None, ...]]:
    """(joints, reached, reasons): the calibrated robot's joints reaching `world` ((N, 4, 4) targets in the
    model's world frame, base included, mm) next to `seeds` (the program's joints, already the nominal
    solution), found as `compensate_poses` finds its calibrated ones: Newton from the seed, a target reached
    only on another configuration (a joint more than MAX_BRANCH_STEP_RAD away) refused with its reason. Where
    a program's joints are given rather than its targets (a tree's relative targets, `models.tree`)."""
    rt = runtime_for(desc, runtime)
    theta = desc.parameters.vector(calibrated)
    t = np.asarray(world, dtype=float).reshape(-1, 4, 4)
    start = np.asarray(seeds, dtype=float).reshape(t.shape[0], desc.n_joints)
    reached, joints, reasons = _near(desc, theta, t, start, rt, nominal=False)
    step = np.max(np.abs(np.nan_to_num(joints) - start), axis=1)
    for i in np.flatnonzero(reached & (step > MAX_BRANCH_STEP_RAD)):
        reached[i] = False
        reasons[i] = (
            f"the calibrated robot reaches it only on another configuration (a joint moves "
            f"{np.degrees(step[i]):.3g}° from the program's): the controller would not follow"
        )
    joints[~reached] = np.nan
    return joints, reached, tuple(reasons)


def _screened(t: Array, reasons: list[str | None]) -> NDArray[np.bool_]:
    """Which targets a solver may see; the others' reasons written. Not a pose (a zero quaternion read as NaN) or
    kilometres away (1e300 mm overflowed the start table's distances, an IndexError): they keep their value."""
    finite = np.asarray(np.isfinite(t).all(axis=(1, 2)), dtype=np.bool_)
    rotations = np.where(finite[:, None, None], t[:, :3, :3], 0.0)
    rotation_ok = finite & np.all(
        np.abs(np.einsum("nij,nkj->nik", rotations, rotations) - np.eye(3)) < 1e-6, axis=(1, 2)
    )
    far = np.max(np.abs(np.nan_to_num(t[:, :3, 3], nan=np.inf)), axis=1) > FAR_MM  # no squares: 1e300 overflows
    for i in np.flatnonzero(~rotation_ok | far):
        reasons[i] = (
            f"farther than {FAR_MM:g} mm from the base: out of any arm's reach"
            if rotation_ok[i]
            else "not a pose: its orientation is not a rotation (a zero or non-finite quaternion or angle)"
        )
    solvable: NDArray[np.bool_] = rotation_ok & ~far
    return solvable


def _tool_groups(tools: Sequence[ArrayLike | None] | None, n: int) -> list[tuple[Array | None, NDArray[np.intp]]]:
    """The distinct tools (as parameter 6-vectors; None: the models' own) and the targets taught with each."""
    if tools is None:
        return [(None, np.arange(n))]
    groups: dict[bytes, tuple[Array | None, list[int]]] = {}
    for i, tool in enumerate(tools):
        if tool is None:
            key, pose6 = b"model", None
        else:
            mat = np.asarray(tool, dtype=float).reshape(4, 4)
            key, pose6 = np.round(mat, 12).tobytes(), matrix_pose6(mat)
        groups.setdefault(key, (pose6, []))[1].append(i)
    return [(pose6, np.asarray(idx, dtype=np.intp)) for pose6, idx in groups.values()]


def _compensate_group(
    desc: RobotDescription,
    cal: Array,
    nom: Array,
    world: Array,
    *,
    seed: Array | None,
    rt: Runtime,
    deadline: float | None = None,
) -> tuple[Array, Array, Array, list[str | None]]:
    """World-frame corrected targets, nominal and calibrated joints, and why each miss (None: reached)."""
    n = world.shape[0]
    start = np.tile(default_seed(desc), (n, 1)) if seed is None else seed
    nominal_reached, nominal_joints, nominal_reasons = _near(
        desc, nom, world, start, rt, nominal=True, deadline=deadline
    )
    why: list[str | None] = [None] * n
    for i in np.flatnonzero(~nominal_reached):
        found = nominal_reasons[i]
        why[i] = found if found == OUT_OF_TIME else f"the nominal robot cannot reach it ({found})"
    q_nom = np.where(nominal_reached[:, None], nominal_joints, np.nan)
    corrected = world.copy()
    q_cal = np.full_like(q_nom, np.nan)
    ok = np.flatnonzero(nominal_reached)
    if ok.size == 0:
        return corrected, q_nom, q_cal, why
    reachable, joints, reasons = _near(desc, cal, world[ok], q_nom[ok], rt, nominal=False, deadline=deadline)
    step = np.max(np.abs(joints - q_nom[ok]), axis=1)
    good = reachable & (step <= MAX_BRANCH_STEP_RAD)
    for k, i in enumerate(ok):
        if not reachable[k]:
            found = reasons[k]
            why[i] = found if found == OUT_OF_TIME else f"the calibrated robot cannot reach it ({found})"
        elif not good[k]:
            why[i] = (
                f"the calibrated robot reaches it only on another configuration (a joint moves "
                f"{np.degrees(step[k]):.3g}° from the nominal solution): the controller would not follow"
            )
    keep = ok[good]
    q_cal[keep] = joints[good]
    if keep.size:
        fk = forward_kinematics(desc, q_cal[keep], nom, runtime=rt)
        corrected[keep] = pose_matrices(fk.positions, fk.rotations)
    return corrected, q_nom, q_cal, why


HOMOTOPY_STEPS = 6
"""The nominal solution is followed from the seed's own pose to the target in this many steps: a path from the
seed stays on the seed's branch (shoulder, elbow, wrist), where Newton straight from a seed 60° away lands on
another branch for 1 target in 3 (UR5-like arm, 25 targets). Measured, 2 000 targets within 30-40° of the
seed: 1 991 on the taught branch with 4 steps, 1 989 with 8."""
WAYPOINT_ITERATIONS = 1
"""Newton iterations at each waypoint before the last (a predictor-corrector: the last point predicts, one
iteration corrects); the target itself is solved to full precision. A waypoint is only where the next solve
starts. Measured, 5 000 targets within 30-40° of the seed, KKT evaluations per target: converged waypoints,
4 steps 19.6, 4 965 on the taught branch; one iteration each, 6 steps 12.1, 4 965 (4 steps 10.2, 4 962)."""


NEAR_SINGULAR = 0.05
"""A path's answer whose Jacobian determinant is below this fraction of the seed's is near a singular
configuration, where another branch's solution can be nearer the seed (the UR5-like arm's shoulder: two
solutions 3° apart): it gets the straight solve as well."""


def _from_seed(batch: IkBatch, world: Array, steps: int) -> tuple[Array, NDArray[np.bool_], NDArray[np.bool_]]:
    """KKT Newton from each seed, along the straight path from the seed's pose to the target (positions
    linearly, rotations along the geodesic) in `steps` steps, each from the last; (v, converged, kept: the
    answer is on the seed's side of the arm's singularities and not near them, `IkBatch.jacobian_determinant`;
    all False where the arm has no such sign)."""
    n = world.shape[0]
    v = batch.seeds.copy()
    fk = forward_kinematics(batch.desc, v, batch.theta, check_ranges=False, runtime=batch.runtime)
    p0, r0 = fk.positions, fk.rotations
    turn = matrix_to_rotvec_np(np.swapaxes(r0, 1, 2) @ world[:, :3, :3])
    alive = np.ones(n, dtype=bool)
    for step in range(1, steps + 1):
        s = step / steps
        rot = r0 @ rotvec_to_matrix_np(s * turn)
        goal = np.hstack([(1 - s) * p0 + s * world[:, :3, 3], np.swapaxes(rot, 1, 2).reshape(n, 9)])
        # Every row at every step, the lost ones too: a batch of another size is another compiled map.
        start = np.where(alive[:, None], v, batch.seeds)
        if step < steps:
            v, _ = batch.newton(start, goal, iterations=WAYPOINT_ITERATIONS)
            alive &= np.isfinite(v).all(axis=1)
        else:
            v, converged = batch.newton(start, goal)
            alive &= converged
    # Once per distinct seed (a program without declared configurations has one).
    _, first, which = np.unique(batch.seeds, axis=0, return_index=True, return_inverse=True)
    seed_pose = np.hstack([p0[first], np.swapaxes(r0[first], 1, 2).reshape(first.size, 9)])
    at_seed = batch.subset(first).jacobian_determinant(batch.seeds[first], seed_pose)
    if at_seed is None:
        return v, alive, np.zeros(n, dtype=bool)
    at_seed = at_seed[which.reshape(-1)]
    at_end = batch.jacobian_determinant(np.where(alive[:, None], v, batch.seeds), batch.target)
    assert at_end is not None
    kept = (np.sign(at_end) == np.sign(at_seed)) & (np.abs(at_end) >= NEAR_SINGULAR * np.abs(at_seed))
    return v, alive, kept & (at_seed != 0)


def _nominal_from_seed(batch: IkBatch, world: Array) -> tuple[Array, NDArray[np.bool_]]:
    """The nominal controller's solution nearest each seed: (v, reached). Along the path from the seed's pose
    (`_from_seed`); where that failed or ended across a singularity from the seed, Newton straight from the
    seed too, and of the two the answer nearest the seed (the IK's own objective): each alone lands on another
    branch for a few targets in 25 (from 60° away). Measured on the UR5-like arm, 10 000 targets within 30-40°
    of the seed: 9 938 on the taught branch by the path alone, 9 940 with the straight solve on every target
    or only on the ~1 % the check sends there; the straight solve was a third of the Newton rows."""
    v, converged, kept = _from_seed(batch, world, HOMOTOPY_STEPS)
    reached = batch.accepted(v, converged)
    again = np.flatnonzero(~(reached & kept))
    if again.size == 0:
        return v, reached
    tries = batch.subset(again)
    v_direct, converged_direct = tries.newton(tries.seeds.copy())
    direct_ok = tries.accepted(v_direct, converged_direct)
    w = batch.w
    d_direct = np.where(direct_ok, np.sum(w * (np.nan_to_num(v_direct) - tries.seeds) ** 2, axis=1), np.inf)
    d_path = np.where(reached[again], np.sum(w * (np.nan_to_num(v[again]) - tries.seeds) ** 2, axis=1), np.inf)
    take = d_direct < d_path
    v[again[take]] = v_direct[take]
    reached[again] |= direct_ok
    return v, reached


GENERAL_CHUNK = 8
"""Targets handed to the general inverse kinematics at a time, the deadline checked between chunks."""
NO_NEAR_SOLUTION = (
    "no solution next to the nominal one (Newton from it did not converge): the target is near a singular "
    "configuration or at the edge of the calibrated robot's reach"
)
OUT_OF_TIME = (
    "not solved in the request's time: Newton from the program's configuration did not reach it, and the general "
    "inverse kinematics (about 0.3 s a target) was not started for it; send fewer such targets at a time"
)


def _near(
    desc: RobotDescription,
    theta: Array,
    world: Array,
    seeds: Array,
    rt: Runtime,
    *,
    nominal: bool,
    deadline: float | None = None,
) -> tuple[NDArray[np.bool_], Array, list[str | None]]:
    """The joints reaching each target nearest its seed: (reached, joints, reasons).

    On a serial arm without model terms, KKT Newton starts from the seed itself, so the answer keeps the seed's
    configuration: the nominal solution the one the program declares (its seed is moved into the declared
    configuration), the calibrated one a small step from the nominal one. The general route (`inverse_kinematics`,
    `compensate`: table starts, multistart, homotopy, IPOPT) takes only the targets Newton leaves; it starts
    from the model's table, not from the seed. Measured on the UR5-like arm, 500 targets seeded at their
    nominal solutions: 1.9 s through the route alone, most of them in its 33-start multistart."""
    n = world.shape[0]
    reached = np.zeros(n, dtype=bool)
    joints = np.full((n, desc.n_joints), np.nan)
    reasons: list[str | None] = [None] * n
    if not desc.has_closure and not desc.terms.any:
        target = np.hstack([world[:, :3, 3], world[:, :3, :3].transpose(0, 2, 1).reshape(n, 9)])
        batch = IkBatch(desc, theta, target, seeds, joint_weights(desc, None), position_only=False, runtime=rt)
        if nominal:
            v, reached = _nominal_from_seed(batch, world)
        else:
            v, converged = batch.newton(seeds.copy())
            reached = batch.accepted(v, converged)
        joints[reached] = np.clip(v[reached], desc.joint_min, desc.joint_max)
    remaining = np.flatnonzero(~reached)
    if not nominal and not desc.has_closure and not desc.terms.any:
        # Newton from q_nom failed for the calibrated robot: the target is near a singular configuration (or
        # out of its reach). The general route starts from its table, not from q_nom, and its answers are then
        # another branch, refused by the 5° check: measured on 3 000 targets each, the UR5-like arm's 12 and an
        # imported UR10e's 19 such targets cost 0.3 s of CPU each in IPOPT and none ended compensated.
        for i in remaining:
            reasons[i] = NO_NEAR_SOLUTION
        return reached, joints, reasons
    chunk = remaining.size if deadline is None else GENERAL_CHUNK
    for at in range(0, remaining.size, max(chunk, 1)):
        rest = remaining[at : at + chunk]
        if deadline is not None and time.monotonic() > deadline:
            for i in remaining[at:]:
                reasons[i] = OUT_OF_TIME
            break
        positions, quats = world[rest, :3, 3], matrix_to_quaternion(world[rest, :3, :3])
        if nominal:
            ik = inverse_kinematics(desc, positions, quats, theta, seed=seeds[rest], runtime=rt)
        else:
            ik = compensate(desc, theta, positions, quats, seed=seeds[rest], runtime=rt)
        reached[rest], joints[rest] = ik.reachable, ik.joints
        for k, i in enumerate(rest):
            reasons[i] = ik.reasons[k]
    return reached, joints, reasons
