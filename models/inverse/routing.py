"""Routing: KKT Newton for every target from its nearest start; IPOPT where a bound is active or Newton did
not converge; IPOPT's nearest reachable pose where the target cannot be reached exactly."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.robot import RobotDescription
from models.description.serial_chain import JointType
from models.engine import cancellation
from models.engine.runtime import Runtime, runtime_for
from models.inverse.kkt import FULL_TURN, kkt_functions, newton_kkt
from models.inverse.nlp import bounds, ik_solvers
from models.inverse.problem import N_TARGET
from models.inverse.starts import start_table
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np

SERIAL_STARTS = 32
"""Table starts tried by Newton (in one batch) per target on a serial arm where its nearest start failed, with
the seed, before IPOPT. A 6R arm has up to 16 IK branches (elbow, shoulder, wrist) and the pose-nearest table
entry often lies on another one, behind a joint limit: on the UR5-like arm, from its nearest start alone 27 %
of full-pose FK targets ended unreachable; with the 8 nearest, the seed and IPOPT's further starts 2-3 in 50
still did (from the default seed), with whole-turn wrapping of ±180° joints and the 32 nearest none in 150.
The IWR (one branch through its hexapod) keeps its single start."""
REACHED_MM = 1e-6
IPOPT_CHUNK = 8
"""Targets per mapped IPOPT call: a stop (models.engine.cancellation) is honoured between chunks, so a request stopped
at its deadline stops within one chunk rather than after the whole batch (measured: 200 unreachable targets, 33 ms each,
were one uninterruptible 6.6 s call per IPOPT stage); chunking costs nothing measurable (a map loops anyway)."""
BOUND_SLACK = 1e-9
NEWTON_ITERATIONS = 15
"""Newton iterations per active set (a path's waypoints take fewer: `models.compensation.poses`)."""


def joints_of(desc: RobotDescription, theta: Array, v: Array) -> Array:
    """The joint vectors of IK variables `v` (serial joints, then the closures' unknowns): each parallel stage's
    legs by its inverse kinematics."""
    if not desc.has_closure:
        return v.copy()
    q = np.empty((v.shape[0], desc.n_joints))
    q[:, : desc.n_chain] = v[:, : desc.n_chain]
    x = v[:, desc.n_chain :]
    for k in desc.closed_stages:
        stage, at = desc.stages[k], desc.placements[k]
        q[:, at.joints] = stage.joints_of_unknowns(x[:, at.unknowns], theta[at.params])
    return q


def periodic_variables(desc: RobotDescription) -> NDArray[np.bool_]:
    """Which IK variables are revolute joints whose range spans a full turn (where an angle and the angle a
    turn away are the same pose)."""
    out = np.zeros(desc.n_ik, dtype=bool)
    moving = [link for link in desc.links if link.joint.moves]
    for k, link in enumerate(moving[: desc.n_chain]):
        out[k] = link.joint is JointType.REVOLUTE and link.joint_max - link.joint_min >= FULL_TURN - 1e-9
    return out


def within_bounds(desc: RobotDescription, theta: Array, v: Array) -> NDArray[np.bool_]:
    lbx, ubx, lbl, ubl = bounds(desc)
    legs = joints_of(desc, theta, v)[:, desc.n_chain :]
    ok = np.all((v >= lbx - BOUND_SLACK) & (v <= ubx + BOUND_SLACK), axis=1)
    within: NDArray[np.bool_] = ok & np.all((legs >= lbl - BOUND_SLACK) & (legs <= ubl + BOUND_SLACK), axis=1)
    return within


@dataclass(frozen=True)
class IkBatch:
    """Targets to solve on one model, and what every routing step shares: the parameters, each target's seed
    (the joints it should stay near), the joint weights, whether the orientation is free, the compiled model.
    `target` rows are the position (mm) then the rotation's columns (`N_TARGET` numbers)."""

    desc: RobotDescription
    theta: Array
    target: Array
    seeds: Array
    w: Array
    position_only: bool
    runtime: Runtime

    def subset(self, idx: NDArray[np.intp]) -> IkBatch:
        """These targets (an index may repeat: one row per start tried)."""
        return replace(self, target=self.target[idx], seeds=self.seeds[idx])

    def newton(
        self, start: Array, goal: Array | None = None, *, iterations: int = NEWTON_ITERATIONS
    ) -> tuple[Array, NDArray[np.bool_]]:
        """KKT Newton from `start` towards `goal` (default: the targets), at most `iterations` per active set;
        (v, converged)."""
        lbx, ubx, _, _ = bounds(self.desc)
        return newton_kkt(
            kkt_functions(self.desc, self.runtime),
            start.copy(),
            self.target if goal is None else goal,
            seed=self.seeds,
            weights=np.broadcast_to(self.w, self.seeds.shape),
            theta=self.theta,
            lower=lbx,
            upper=ubx,
            position_only=self.position_only,
            periodic=periodic_variables(self.desc),
            iterations=iterations,
        )

    def jacobian_determinant(self, v: Array, goal: Array) -> NDArray[np.float64] | None:
        """The determinant of the TCP equations' Jacobian at `v`, `goal` being `v`'s own pose (there that
        Jacobian is the arm's Jacobian with rows scaled by positive factors): its sign says which side of the
        arm's singular configurations `v` lies on (two solutions of one sign are on one branch unless a path
        between them crossed the singularities twice), its size how far from them. None where the problem is
        not square (more variables than equations: a redundant arm has no such sign)."""
        k, m = self.desc.n_ik, 3 if self.position_only else 6
        if k != m:
            return None
        name = "ik_kkt_position" if self.position_only else "ik_kkt_pose"
        n = v.shape[0]
        _, jf, _ = kkt_functions(self.desc, self.runtime).batch(
            name, v, np.zeros((n, m)), goal, self.seeds, np.broadcast_to(self.w, self.seeds.shape), self.theta
        )
        return np.asarray(np.linalg.det(jf[:, k:, :k]), dtype=float)

    def accepted(self, v: Array, converged: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Converged inside every range, and (a serial arm) on the wanted orientation, not half a turn away."""
        ok = converged & within_bounds(self.desc, self.theta, v)
        if not self.desc.has_closure:
            ok &= _not_flipped(self, v)
        return ok

    def nearest_to_seed(self, v: Array, ok: NDArray[np.bool_], k: int) -> tuple[NDArray[np.bool_], NDArray[np.intp]]:
        """Of `k` solutions a target (rows grouped by target), the accepted one nearest the seed (the NLP's own
        objective): (found, the row picked)."""
        r = v.shape[0] // k
        distance = np.where(ok, np.sum(self.w * (np.nan_to_num(v) - self.seeds) ** 2, axis=1), np.inf).reshape(r, k)
        best = np.argmin(distance, axis=1)
        return np.isfinite(distance[np.arange(r), best]), np.arange(r) * k + best


def route(
    desc: RobotDescription,
    theta: Array,
    target: Array,
    seeds: Array,
    w: Array,
    *,
    position_only: bool,
    runtime: Runtime,
) -> tuple[Array, list[str]]:
    """Route each target: KKT Newton from the nearest start; IPOPT where a bound is active or Newton did not
    converge; IPOPT's nearest reachable pose where the target cannot be reached exactly."""
    batch = IkBatch(desc, theta, target, seeds, w, position_only, runtime)
    n = target.shape[0]
    start = start_table(desc, theta, runtime).nearest(target, position_only=position_only)
    v, converged = batch.newton(start)
    methods = ["newton"] * n
    good = batch.accepted(v, converged)
    if not desc.has_closure:
        for fallback in (_serial_multistart, _homotopy):  # each on the targets still failed
            rest = np.flatnonzero(~good)
            if rest.size == 0:
                break
            found, v_r, start_r = fallback(batch.subset(rest))
            v[rest[found]] = v_r[found]
            start[rest[found]] = start_r[found]
            good[rest[found]] = True

    rest = np.flatnonzero(~good)
    if rest.size:
        v[rest], exact = ipopt_solutions(batch.subset(rest), start=start[rest], exact=True)
        for i in rest:
            methods[i] = "ipopt"
        missed = rest[~exact]
        if missed.size and not desc.has_closure:
            missed = _ipopt_other_starts(batch, v=v, missed=missed)
        if missed.size:
            v[missed], _ = ipopt_solutions(batch.subset(missed), start=start[missed], exact=False)
            for i in missed:
                methods[i] = "ipopt-nearest"
    return v, methods


def _serial_multistart(batch: IkBatch) -> tuple[NDArray[np.bool_], Array, Array]:
    """Newton from the `SERIAL_STARTS` table poses nearest each target in task space and from its seed, all in
    one batch; per target the solution nearest the seed among those accepted. (found, v, the start that gave
    it)."""
    r = batch.target.shape[0]
    table = start_table(batch.desc, batch.theta, batch.runtime)
    # The seed too: a program's own joints (compensation) are usually on the right branch.
    nearest = table.nearest_k(batch.target, SERIAL_STARTS, position_only=batch.position_only)
    starts = np.concatenate([nearest, batch.seeds[:, None]], 1)
    k = starts.shape[1]
    flat = starts.reshape(r * k, -1)
    tries = batch.subset(np.repeat(np.arange(r), k))
    v, conv = tries.newton(flat)
    found, pick = tries.nearest_to_seed(v, tries.accepted(v, conv), k)
    return found, v[pick], flat[pick]


HOMOTOPY_STARTS = 32
HOMOTOPY_STEPS = 6
"""Where Newton from every start failed, it follows the straight path (positions linearly, rotations along
the geodesic) from each of the `HOMOTOPY_STARTS` nearest table poses to the target in this many steps, each
from the last. Newton's basin on a 6R arm can be narrow (a UR5-like target near full extension: from the
truth + 0.3 rad on every joint it diverged, and the nearest table entry was 46° away), while a path from a
start stays on the start's branch. Measured, full-pose FK targets from the default seed: UR5-like, iiwa-like
and track arm 250/250 each (the direct starts alone left 1 in 250 on the UR5-like arm)."""


def _homotopy(batch: IkBatch) -> tuple[NDArray[np.bool_], Array, Array]:
    """Newton continuation from the nearest table poses to each target; (found, v, start) as the multistart."""
    r, k = batch.target.shape[0], HOMOTOPY_STARTS
    table = start_table(batch.desc, batch.theta, batch.runtime)
    rows = table.nearest_k_index(batch.target, k, position_only=batch.position_only).reshape(-1)
    tries = batch.subset(np.repeat(np.arange(r), k))
    p0, r0 = table.positions[rows], table.rotations[rows]
    p1 = tries.target[:, :3]
    r1 = tries.target[:, 3:12].reshape(-1, 3, 3).transpose(0, 2, 1)
    turn = matrix_to_rotvec_np(r0.transpose(0, 2, 1) @ r1)
    v = table.start[rows].copy()
    alive = np.ones(r * k, dtype=bool)
    for step in range(1, HOMOTOPY_STEPS + 1):
        s = step / HOMOTOPY_STEPS
        rot = r0 @ rotvec_to_matrix_np(s * turn)
        goal = np.hstack([(1 - s) * p0 + s * p1, rot.transpose(0, 2, 1).reshape(-1, 9)])
        idx = np.flatnonzero(alive)
        if idx.size == 0:
            break
        v[idx], conv = tries.subset(idx).newton(v[idx], goal[idx])
        alive[idx[~conv]] = False
    found, pick = tries.nearest_to_seed(v, alive & tries.accepted(v, alive), k)
    return found, v[pick], table.start[rows][pick]


def _not_flipped(batch: IkBatch, v: Array) -> NDArray[np.bool_]:
    """The orientation equations (sin(angle)·axis) also vanish half a turn away: a serial arm's wrist can
    converge there (seen on the track arm, 1 target in 40); such an answer is no answer."""
    if batch.position_only:
        return np.ones(v.shape[0], dtype=bool)
    safe = np.where(np.isfinite(v), v, 0.0)
    kinematics = runtime_for(batch.desc, batch.runtime).kinematics
    _, rot = kinematics.batch("pose_at", safe, batch.theta, np.zeros((v.shape[0], 6)))
    wanted = batch.target[:, 3:12].reshape(-1, 3, 3).transpose(0, 2, 1)
    return np.asarray(np.einsum("nij,nij->n", rot, wanted) > 1.0)  # trace(R Rtᵀ) > 1: angle below 90°


IPOPT_STARTS = 8
"""Table starts IPOPT tries on a serial arm where Newton failed everywhere, multistart and homotopy included
(before those existed, from the default seed: track arm 84 % of full-pose FK targets from one start, 100 %
from four; UR5-like 94 % from four; iiwa-like 98 % from eight). Since then 1 of the 750 measured FK targets
went on to IPOPT (iiwa-like; IPOPT solved it): it stays for such and for targets not reachable exactly."""


def _ipopt_other_starts(batch: IkBatch, *, v: Array, missed: NDArray[np.intp]) -> NDArray[np.intp]:
    """Exact IPOPT from the next nearest starts for the targets still missed (solutions written into `v`);
    those still missed after."""
    table = start_table(batch.desc, batch.theta, batch.runtime)
    for j in range(1, IPOPT_STARTS):
        if missed.size == 0:
            break
        these = batch.subset(missed)
        other = table.nearest_k(these.target, j + 1, position_only=batch.position_only)[:, j, :]
        v_j, exact = ipopt_solutions(these, start=other, exact=True)
        v[missed[exact]] = v_j[exact]
        missed = missed[~exact]
    return missed


def ipopt_solutions(batch: IkBatch, *, start: Array, exact: bool) -> tuple[Array, NDArray[np.bool_]]:
    """IPOPT on each target, `IPOPT_CHUNK` targets per mapped call; returns the solutions and whether the
    equations hold."""
    desc, theta, target, seeds, w, position_only = (
        batch.desc,
        batch.theta,
        batch.target,
        batch.seeds,
        batch.w,
        batch.position_only,
    )
    rt = runtime_for(desc, batch.runtime)
    n = target.shape[0]
    solvers = ik_solvers(desc, rt)
    solver = solvers.solver(exact=exact, position_only=position_only)
    mapped = rt.artefact("ik_nlp_chunk", (exact, position_only), lambda: solver.map(IPOPT_CHUNK))
    lbx, ubx, lbl, ubl = bounds(desc)
    m = 3 if position_only else 6
    lbg = np.r_[np.zeros(m), lbl] if exact else lbl
    ubg = np.r_[np.zeros(m), ubl] if exact else ubl
    params = np.hstack(
        [target[:, :N_TARGET], seeds, np.broadcast_to(w, seeds.shape), np.broadcast_to(theta, (n, theta.size))]
    )
    v = np.empty((n, lbx.size))
    g = np.empty((n, lbg.size))
    for lo in range(0, n, IPOPT_CHUNK):
        cancellation.check()  # between chunks: a request whose client left or whose deadline passed stops here
        hi = min(lo + IPOPT_CHUNK, n)
        # A full chunk in one mapped call; the remainder one solver call per target (a map of another size would
        # be a Function built per request).
        call, k = (mapped, IPOPT_CHUNK) if hi - lo == IPOPT_CHUNK else (solver, 1)
        for a in range(lo, hi, k):
            out = call(
                x0=start[a : a + k].T,
                p=params[a : a + k].T,
                lbx=np.tile(lbx, (k, 1)).T,
                ubx=np.tile(ubx, (k, 1)).T,
                lbg=np.tile(lbg, (k, 1)).T,
                ubg=np.tile(ubg, (k, 1)).T,
            )
            v[a : a + k] = np.asarray(out["x"], dtype=float).T.reshape(k, -1)
            g[a : a + k] = np.asarray(out["g"], dtype=float).T.reshape(k, -1)
    met = np.abs(g[:, :m]).max(axis=1) <= REACHED_MM if exact else np.zeros(n, dtype=bool)
    if exact and not desc.has_closure:
        met &= _not_flipped(batch, v)
    return v, met & within_bounds(desc, theta, v)
