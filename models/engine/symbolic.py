"""The kinematic model as CasADi expressions: FK, residuals, implicit-function Jacobians.

The graphs depend only on the structure of a description (per link its
convention, joint type and Hayati parameter; where the hexapod sits, if there
is one): nominal values, base, tool and data are inputs. So every IWR, whatever its nominal geometry, shares one
set of Functions (held by its `models.engine.runtime.Runtime`), and a request never
triggers a build.

Internal units: mm and rad. `q` is the joint vector `[q_chain..., l1..l6]`
(no legs without a hexapod),
`params` the full parameter vector, `platform` the hexapod pose
`[x, y, z, α, β, γ]` of frame {5} in {4} (Z-Y-X Euler).

Two routes to the same numbers, from the same expressions:
- `hexapod_fk`, `fk`, `fk_jacobian`: Newton through `casadi.rootfinder`,
  derivatives by the implicit function theorem inside CasADi's AD. Fully
  differentiable MX graphs, for NLPs that nest the hexapod FK.
- `*_at` Functions take the solved platform pose as an input and apply the
  implicit function theorem explicitly (`dx/dθ = -G_x⁻¹ G_θ`), in SX; with
  `newton_solve` (unrolled Newton steps) they evaluate whole batches at native
  speed (see `native` and `batch`). Tests check that both routes agree.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, field

import casadi as ca

from models.description import hexapod as hx
from models.description.robot import (
    RobotDescription,
    carriage_transform,
    links_transform,
    pose_transform,
    tcp_transform,
)
from models.description.serial_chain import Convention, JointType
from models.description.terms import N_CONDITIONS
from models.transforms import matrix_to_rotvec

NEWTON_OPTIONS = {
    "abstol": 1e-11,
    "abstolStep": 1e-12,
    "max_iter": 30,
    "error_on_fail": False,
    "print_iteration": False,
}
NEWTON_STEPS_PER_CALL = 6
"""Newton steps unrolled in `newton_solve`; from the home seed the workspace needs 4-5."""


def rotation_jacobian(r: ca.SX | ca.MX, dr_dp: ca.SX | ca.MX) -> ca.SX | ca.MX:
    """Columns vee(∂R/∂p_j · Rᵀ): the small world-frame rotation per unit change of each p_j.

    `dr_dp` is the Jacobian of vec(R) (column-major) with respect to p.
    """

    def d(a: int, k: int) -> ca.SX | ca.MX:
        return dr_dp[a + 3 * k, :]

    wx = d(2, 0) * r[1, 0] + d(2, 1) * r[1, 1] + d(2, 2) * r[1, 2]
    wy = d(0, 0) * r[2, 0] + d(0, 1) * r[2, 1] + d(0, 2) * r[2, 2]
    wz = d(1, 0) * r[0, 0] + d(1, 1) * r[0, 1] + d(1, 2) * r[0, 2]
    return ca.vertcat(wx, wy, wz)


def pose_jacobian(position: ca.SX | ca.MX, rotation: ca.SX | ca.MX, dvec_dp: ca.SX | ca.MX) -> ca.SX | ca.MX:
    """6 x n pose Jacobian (dp; dω) from the Jacobian of [position; vec(R)]."""
    return ca.vertcat(dvec_dp[0:3, :], rotation_jacobian(rotation, dvec_dp[3:12, :]))


def kinematic_functions(desc: RobotDescription) -> dict[str, ca.Function]:
    """Every kinematic Function of `desc`'s structure (see the module docstring for the two routes).

    A structure with model terms (`models.description.terms`) gives every Function that depends on them one more input,
    last: `conditions` (7 per pose). Without terms the graphs are exactly the geometric ones.
    """
    # Long on purpose: one symbolic graph: every Function below shares the same symbols and sub-expressions (the
    # closure, its Jacobians, the implicit-function terms), so splitting it would pass a dozen symbols between
    # helpers.
    n_chain = desc.n_chain
    with_terms = desc.terms.any

    q = ca.SX.sym("q", desc.n_joints)
    params = ca.SX.sym("params", desc.n_params)
    x = ca.SX.sym("platform", desc.n_platform)
    cond = ca.SX.sym("conditions", N_CONDITIONS)
    q_chain, legs = q[:n_chain], q[n_chain:]
    extra, extra_names = ([cond], ["conditions"]) if with_terms else ([], [])
    fn: dict[str, ca.Function] = {}

    # ---- the hexapod alone (a robot whose one parallel stage is a hexapod)
    if _sole_hexapod(desc):
        s_hex = desc.slices["hexapod"]
        _hexapod_functions(fn, ca.SX.sym("platform", 6), ca.SX.sym("hexapod_params", s_hex.stop - s_hex.start))

    # ---- closure and Newton, with the closures' unknowns (platform poses) as unknown. Without a closure the
    # platform variable is kept (one signature for every structure) but pinned by g = x: one Newton step solves
    # it exactly, the TCP does not depend on it, and its implicit-function terms vanish.
    q_eff = thermal_axes(desc, q_chain, params, cond) if with_terms else q_chain
    deflection = joint_deflection(desc, q_eff, x, params, cond)
    if deflection is not None:
        fn["joint_deflection"] = ca.Function(
            "joint_deflection", [q, params, cond], [deflection], ["q", "params", "conditions"], ["deflection"]
        )
        q_eff = q_eff + deflection
    joints = EffectiveJoints.of(q_chain, q_eff)
    q_seen, d, at = joints.seen, joints.derivative, joints.at
    geometric = stacked_closure(desc, ca.vertcat(q_chain, legs), x, params)
    if not desc.has_closure:
        closure = Closure(x)
    elif with_terms:
        closure = terms_closure(desc, q_seen, legs, x, params=params, cond=cond)
    else:
        closure = Closure(geometric)
    g_x, g_params, g_q = closure.jacobians(x, params, q, derivative=d)
    g = at(closure.value)
    names_at = ["q", "params", "platform", *extra_names]
    ins_at = [q, params, x, *extra]
    fn["closure"] = ca.Function("closure", ins_at, [g], names_at, ["residual"])
    # Newton steps: with compliance the geometric closure's Jacobian is used (the load's leg changes are
    # micrometres, so the iteration still contracts by ~1e-4 per step) and keeps the unrolled graph small;
    # the implicit-function derivatives below use the exact one.
    g_x_step = ca.jacobian(geometric, x) if with_terms and desc.has_closure else g_x
    x_k = x
    for _ in range(NEWTON_STEPS_PER_CALL if desc.has_closure else 1):
        g_k = ca.substitute(g, x, x_k)
        x_k = x_k - ca.solve(ca.substitute(g_x_step, x, x_k), g_k)
    fn["newton_solve"] = ca.Function(
        "newton_solve",
        ins_at,
        [x_k, ca.norm_inf(ca.substitute(g, x, x_k))],
        ["q", "params", "platform_seed", *extra_names],
        ["platform", "closure_inf"],
    )

    # ---- TCP pose given the solved platform; implicit-function-theorem derivatives
    p_meas = ca.SX.sym("position_meas", 3)
    r_meas = ca.SX.sym("rotation_meas", 3, 3)
    t = tcp_transform(desc, ca.vertcat(q_seen, legs), x, params)
    position, rotation = t[0:3, 3], t[0:3, 0:3]
    vec = ca.vertcat(position, ca.vec(rotation))
    dvec_dx = d(vec, x)
    if desc.has_closure:
        dx_dparams = -ca.solve(g_x, g_params)
        dx_dq = -ca.solve(g_x, g_q)
    else:
        dx_dparams, dx_dq = ca.SX(desc.n_platform, desc.n_params), ca.SX(desc.n_platform, desc.n_joints)
    d_params = d(vec, params) + dvec_dx @ dx_dparams
    d_q = d(vec, q) + dvec_dx @ dx_dq
    j_params = at(pose_jacobian(position, rotation, d_params))
    j_q = at(pose_jacobian(position, rotation, d_q))
    residual_of = ca.vertcat(position - p_meas, matrix_to_rotvec(rotation @ r_meas.T))
    residual = at(residual_of)
    d_res = at(d(residual_of, params) + d(residual_of, x) @ dx_dparams)
    position, rotation, t = at(position), at(rotation), at(t)
    # The TCP pose at solved platforms, alone or with its parameter or joint Jacobian: one input list for all.
    for name, outputs in (
        ("pose_at", {}),
        ("pose_jacobian_at", {"J": j_params}),
        ("joint_jacobian_at", {"J_q": j_q}),
    ):
        named = {"position": position, "rotation": rotation, **outputs}
        fn[name] = ca.Function(name, ins_at, list(named.values()), names_at, list(named))

    res_names = ["q", "params", "platform", "position_meas", "rotation_meas", *extra_names]
    res_ins = [q, params, x, p_meas, r_meas, *extra]
    fn["residual_at"] = ca.Function("residual_at", res_ins, [residual], res_names, ["residual"])
    fn["residual_jacobian_at"] = ca.Function(
        "residual_jacobian_at",
        res_ins,
        [residual, d_res],
        res_names,
        ["residual", "J"],
    )

    # ---- carriage alone (world <- {n}) and the TCP as a function of the platform pose
    fn["carriage_fk"] = ca.Function(
        "carriage_fk",
        [q_chain, params, *extra],
        [carriage_transform(desc, q_eff, params)],
        ["q_chain", "params", *extra_names],
        ["T"],
    )
    fn["tcp_from_platform"] = ca.Function(
        "tcp_from_platform", [q_chain, x, params, *extra], [t], ["q_chain", "platform", "params", *extra_names], ["T"]
    )

    _rootfinder_functions(fn, desc, g, x=x, q=q, params=params, cond=cond)
    return fn


def _rootfinder_functions(
    fn: dict[str, ca.Function], desc: RobotDescription, g: ca.SX, *, x: ca.SX, q: ca.SX, params: ca.SX, cond: ca.SX
) -> None:
    """The rootfinder route (MX): Newton inside CasADi, derivatives by its IFT."""
    with_terms = desc.terms.any
    extra_names = ["conditions"] if with_terms else []
    inputs = ca.vertcat(q, params, cond) if with_terms else ca.vertcat(q, params)
    newton = ca.rootfinder("hexapod_newton", "newton", ca.Function("g", [x, inputs], [g]), NEWTON_OPTIONS)
    q_mx = ca.MX.sym("q", desc.n_joints)
    p_mx = ca.MX.sym("params", desc.n_params)
    c_mx = ca.MX.sym("conditions", N_CONDITIONS)
    extra_mx = [c_mx] if with_terms else []
    seed = ca.MX.sym("platform_seed", desc.n_platform)
    platform = newton(seed, ca.vertcat(q_mx, p_mx, *extra_mx))
    pos_mx, rot_mx = fn["pose_at"](q_mx, p_mx, platform, *extra_mx)
    fk_names = ["q", "params", "platform_seed", *extra_names]
    fn["fk"] = ca.Function(
        "fk",
        [q_mx, p_mx, seed, *extra_mx],
        [pos_mx, rot_mx, platform],
        fk_names,
        ["position", "rotation", "platform"],
    )
    vec_mx = ca.vertcat(pos_mx, ca.vec(rot_mx))
    fn["fk_jacobian"] = ca.Function(
        "fk_jacobian",
        [q_mx, p_mx, seed, *extra_mx],
        [pos_mx, rot_mx, platform, pose_jacobian(pos_mx, rot_mx, ca.jacobian(vec_mx, p_mx))],
        fk_names,
        ["position", "rotation", "platform", "J"],
    )
    if _sole_hexapod(desc):
        # The hexapod alone, at the reference conditions: its geometric closure.
        s_hex = desc.slices["hexapod"]
        x6, legs, hp = (
            ca.SX.sym("platform", 6),
            ca.SX.sym("legs", 6),
            ca.SX.sym("hexapod_params", s_hex.stop - s_hex.start),
        )
        geo = ca.rootfinder(
            "hexapod_newton_geometric",
            "newton",
            ca.Function("g", [x6, ca.vertcat(legs, hp)], [hx.closure_residual(x6, legs, hp)]),
            NEWTON_OPTIONS,
        )
        legs_mx = ca.MX.sym("legs", 6)
        hp_mx = ca.MX.sym("hexapod_params", s_hex.stop - s_hex.start)
        seed6 = ca.MX.sym("platform_seed", 6)
        fn["hexapod_fk"] = ca.Function(
            "hexapod_fk",
            [legs_mx, hp_mx, seed6],
            [geo(seed6, ca.vertcat(legs_mx, hp_mx))],
            ["legs", "hexapod_params", "platform_seed"],
            ["platform"],
        )


def _sole_hexapod(desc: RobotDescription) -> bool:
    """Whether the robot's one parallel stage is a hexapod (the hexapod-alone Functions then exist)."""
    return len(desc.closed_stages) == 1 and desc.hexapod_at is not None


def stacked_closure(desc: RobotDescription, q: ca.SX, x: ca.SX, params: ca.SX) -> ca.SX:
    """Every parallel stage's closure equations, stacked in stage order (the geometric ones): zero where the
    unknowns `x` agree with the joints `q`. Empty without a parallel stage."""
    parts = []
    for stage, at in zip(desc.stages, desc.placements, strict=True):
        g = stage.closure(q[at.joints], x[at.unknowns], params[at.params])
        if g is not None:
            parts.append(g)
    return ca.vertcat(*parts) if parts else ca.SX(0, 1)


def joint_deflection(desc: RobotDescription, q_chain: ca.SX, x: ca.SX, params: ca.SX, cond: ca.SX) -> ca.SX | None:
    """A serial robot's compliance: k_j τ_j per serial joint (0 for prismatic ones), τ_j (N·m) the payload's
    gravity torque about joint j's axis at the joints `q_chain`; None without the term."""
    if not desc.terms.compliance or desc.has_closure:
        return None
    base = pose_transform(params[desc.slices["base"]])
    tcp = tcp_transform(desc, q_chain, x, params)
    cog_world = tcp[0:3, 0:3] @ cond[4:7] + tcp[0:3, 3]
    # frames[i] = world <- {i}, each from the one before (one product per link, shared by every joint's axis).
    frames = [base]
    for i in range(len(desc.links)):
        frames.append(frames[-1] @ links_transform(desc, i, i + 1, q_chain, params))
    out: list[ca.SX] = []
    k = 0
    for i, link in enumerate(desc.links):
        if not link.joint.moves:
            continue
        if link.joint is JointType.REVOLUTE:
            # The joint's axis: z of frame {i} for standard DH (Rz first), of frame {i+1} for modified DH.
            frame = frames[i if link.convention is Convention.DH else i + 1]
            axis, origin = frame[0:3, 2], frame[0:3, 3]
            torque = ca.dot(axis, ca.cross(cog_world - origin, cond[1:4])) / 1000.0  # N·mm -> N·m
            out.append(params[desc.term_index[f"compliance.joint{k + 1}"]] * torque)
        else:
            out.append(ca.SX(0))
        k += 1
    return ca.vertcat(*out)


def thermal_axes(desc: RobotDescription, q_chain: ca.SX, params: ca.SX, cond: ca.SX) -> ca.SX:
    """The serial joints with each prismatic travel scaled by (1 + κ_axes ΔT); revolute joints unchanged."""
    if "thermal.axes" not in desc.term_index:
        return q_chain
    scale = 1 + params[desc.term_index["thermal.axes"]] * cond[0]
    prismatic = [link.joint is JointType.PRISMATIC for link in desc.moving_links]
    return ca.vertcat(*[q_chain[k] * scale if p else q_chain[k] for k, p in enumerate(prismatic)])


Derivative = Callable[[ca.SX, ca.SX], ca.SX]
"""(expression, variables) -> the expression's Jacobian with respect to the variables."""


@dataclass(frozen=True)
class EffectiveJoints:
    """The serial joints the chain sees: the commanded ones, or under model terms functions of the parameters
    and conditions (thermal travel, compliant deflection).

    Differentiated through by CasADi's AD, those functions are repeated in every direction of the TCP's
    Jacobians (a compliant 6R arm's pose Jacobian: 48 900 SX instructions). So the graphs use a symbol `seen`
    for them, the chain rule adds ∂e/∂seen · ∂value/∂v (`derivative`), and `at` puts `value` in at the end:
    the same derivatives in 27 600 instructions. Without terms `seen` is the commanded joints themselves.
    """

    seen: ca.SX
    value: ca.SX | None = None
    _of_value: dict[int, ca.SX] = field(default_factory=dict, compare=False)

    @classmethod
    def of(cls, commanded: ca.SX, effective: ca.SX) -> EffectiveJoints:
        if effective is commanded:
            return cls(commanded)
        return cls(ca.SX.sym("q_effective", commanded.numel()), effective)

    def derivative(self, expr: ca.SX, wrt: ca.SX) -> ca.SX:
        direct = ca.jacobian(expr, wrt)
        if self.value is None:
            return direct
        # The joints' own Jacobian once per variable set (q, params, platform), shared by every expression.
        key = id(wrt)
        if key not in self._of_value:
            self._of_value[key] = ca.jacobian(self.value, wrt)
        return direct + ca.jacobian(expr, self.seen) @ self._of_value[key]

    def at(self, expr: ca.SX) -> ca.SX:
        return expr if self.value is None else ca.substitute(expr, self.seen, self.value)


@dataclass(frozen=True)
class Closure:
    """The closure residual g (`value`) and its Jacobians.

    With compliance g holds the leg tensions t = J⁻ᵀ w, a symbolic 6 × 6 solve. Differentiated through by
    CasADi's AD, that solve is expanded once per direction: ~50 000 SX instructions per Jacobian and a minute of
    C compiler for one structure's library. Here t is instead a symbol `tension` in `of_tension` and in the
    statics `balance` h = Jᵀ t − w = 0, and the Jacobians follow from the implicit-function theorem,
    dg/dv = ∂g/∂v − ∂g/∂t (∂h/∂t)⁻¹ ∂h/∂v at t = `solved`: the same derivatives, one small solve.
    """

    value: ca.SX
    of_tension: ca.SX | None = None
    tension: ca.SX | None = None
    balance: ca.SX | None = None
    solved: ca.SX | None = None

    def jacobians(self, *wrt: ca.SX, derivative: Derivative = ca.jacobian) -> list[ca.SX]:
        """dg/dv for each v of `wrt`, `derivative` the total derivative of an expression (see
        `EffectiveJoints`)."""
        if self.of_tension is None or self.tension is None or self.balance is None or self.solved is None:
            return [derivative(self.value, v) for v in wrt]
        t, h = self.tension, self.balance
        partial = ca.horzcat(*[derivative(self.of_tension, v) for v in wrt])
        dt = -ca.solve(ca.jacobian(h, t), ca.horzcat(*[derivative(h, v) for v in wrt]))
        total = ca.substitute(partial + ca.jacobian(self.of_tension, t) @ dt, t, self.solved)
        columns = [0]
        for v in wrt:
            columns.append(columns[-1] + v.numel())
        return [total[:, a:b] for a, b in itertools.pairwise(columns)]


def terms_closure(
    desc: RobotDescription, q_chain_eff: ca.SX, legs: ca.SX, x: ca.SX, *, params: ca.SX, cond: ca.SX
) -> Closure:
    """The leg equations with the terms: |p + R b_i − a_i| = (l_i + δl_i)(1 + κ_legs ΔT) + c_i t_i.

    t_i are the leg tensions that carry the payload, t = J⁻ᵀ w (statics of the thesis Jacobian, eq. 48,
    whose twist is the platform origin's velocity and the angular velocity in {4}); w is the payload's
    gravity force and its moment about the platform origin, both in {4}.
    """
    hp = params[desc.slices["hexapod"]]
    v = hx.leg_vectors(x, hp)
    _, _, offsets = hx.split_hexapod_params(hp)
    length = ca.sqrt(ca.sum1(v * v)).T
    target = legs + offsets
    if "thermal.legs" in desc.term_index:
        target = target * (1 + params[desc.term_index["thermal.legs"]] * cond[0])
    if desc.terms.compliance:
        carriage = carriage_transform(desc, q_chain_eff, params)
        r4 = carriage[0:3, 0:3]
        tcp = tcp_transform(desc, q_chain_eff, x, params)
        cog_world = tcp[0:3, 0:3] @ cond[4:7] + tcp[0:3, 3]
        origin_world = r4 @ x[0:3] + carriage[0:3, 3]
        force = r4.T @ cond[1:4]
        arm = r4.T @ (cog_world - origin_world)
        wrench = ca.vertcat(force, ca.cross(arm, force))
        statics = hx.thesis_jacobian(x, hp).T
        compliance = ca.vertcat(*[params[desc.term_index[f"compliance.leg{i + 1}"]] for i in range(hx.N_LEGS)])
        tension = ca.SX.sym("tension", hx.N_LEGS)
        solved = ca.solve(statics, wrench)
        of_tension = length - (target + compliance * tension)
        return Closure(
            ca.substitute(of_tension, tension, solved),
            of_tension=of_tension,
            tension=tension,
            balance=statics @ tension - wrench,
            solved=solved,
        )
    return Closure(length - target)


def _hexapod_functions(fn: dict[str, ca.Function], x: ca.SX, hp_only: ca.SX) -> None:
    """The hexapod's own maps of (platform pose, its parameters): closed-form IK and the thesis Jacobian."""
    for name, output, output_name in (
        ("hexapod_ik", hx.actuator_lengths(x, hp_only), "legs"),
        ("hexapod_jacobian", hx.thesis_jacobian(x, hp_only), "J"),
    ):
        fn[name] = ca.Function(name, [x, hp_only], [output], ["platform", "hexapod_params"], [output_name])


NATIVE_FUNCTIONS = (
    "newton_solve",
    "closure",
    "pose_at",
    "pose_jacobian_at",
    "joint_jacobian_at",
    "residual_at",
    "residual_jacobian_at",
    "hexapod_ik",
    "hexapod_jacobian",
    "carriage_fk",
)


def densified(f: ca.Function) -> ca.Function:
    sx_in = f.sx_in()
    outs = [ca.densify(o) for o in f.call(sx_in)]
    return ca.Function(f.name(), sx_in, outs, f.name_in(), f.name_out())
