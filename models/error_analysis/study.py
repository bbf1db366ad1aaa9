"""The thesis's tolerance study (§4.5): how far manufacturing errors move the TCP.

For random poses inside the workspace and a Monte Carlo of parameter-error
draws within the given tolerances, the TCP pose error at the *same joint
readings* is computed three times — carriage errors alone, hexapod errors
alone, all together — and each time by two models:

- exact: forward kinematics of the perturbed robot (`forward_kinematics`
  with `nominal + δ`), compared with the nominal robot's pose;
- first order: the identification Jacobian at the nominal pose times δ.

Position errors are in mm; orientation errors are the small world-frame
rotation vector `log(R_perturbed R_nominalᵀ)` (rad inside, degrees in
`export`), the same convention as the Jacobian's rotation rows, so the two
models are directly comparable and their difference is the linearisation
error, quadratic in the tolerances.

Base and tool transforms are not perturbed: the thesis's study has neither
(its world frame is the carriage's base, its TCP the platform centre), and a
calibration registers both against the instrument anyway.

Statistics, the report and the figures of a study live beside it (`statistics`, `report`, `plot`);
the command line is `python -m models.error_analysis --help`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.error_analysis.magnitudes import ErrorMagnitudes
from models.error_analysis.result import SUBSYSTEMS, ErrorAnalysisResult, PoseErrors, WorstCase
from models.error_analysis.statistics import Array
from models.errors import InvalidInput, NonFiniteValue, UnreachablePose, WrongShape
from models.kinematics import ForwardResult, as_joint_array, forward_kinematics
from models.transforms import matrix_to_rotvec_np
from models.workspace import sample_workspace

DISTRIBUTIONS: tuple[str, ...] = ("sign", "uniform")

MAX_POSES = 10_000
MAX_DRAWS = 10_000
MAX_EVALUATIONS = 100_000
"""poses × draws. Each costs three perturbed FK solves (~35 µs here) and 48 stored numbers (~400 B):
the cap keeps one study under ~40 MB and ~7 s on a 2-core machine."""

_DRAW_STREAM = 1
"""Second word of the draws' seed, so poses (seeded by `seed` alone) do not depend on the number of draws."""


@dataclass(frozen=True, eq=False)
class _Nominal:
    joints: Array
    positions: Array
    rotations: Array
    platforms: Array
    jacobians: Array
    carriage_frames: Array
    """(N, 4, 4) world <- carriage end frame {n}: the hexapod's base plate."""
    runtime: Runtime
    """The structure's runtime, which every perturbed evaluation of the study uses."""


def _nominal(desc: RobotDescription, joints: Array, runtime: Runtime | None = None) -> _Nominal:
    theta0 = desc.parameters.nominal
    rt = runtime_for(desc, runtime)
    fk = forward_kinematics(desc, joints, theta0, jacobian=True, runtime=rt)
    (frames,) = rt.kinematics.batch("carriage_fk", joints[:, : desc.n_chain], theta0)
    return _Nominal(joints, fk.positions, fk.rotations, fk.platforms, fk.jacobians, frames, rt)


def _pose_difference(positions: Array, rotations: Array, ref_positions: Array, ref_rotations: Array) -> Array:
    """(N, 6): position difference and the world-frame rotation vector log(R R_refᵀ)."""
    return np.concatenate(
        [positions - ref_positions, matrix_to_rotvec_np(rotations @ ref_rotations.transpose(0, 2, 1))], axis=1
    )


def _perturbed_fk(
    desc: RobotDescription, nominal: _Nominal, params: Array, *, draw: int | None, pose: int | None = None
) -> ForwardResult:
    """FK of a perturbed robot at the nominal joint readings (all poses, or one); draw None = worst case."""
    rows = slice(None) if pose is None else slice(pose, pose + 1)
    try:
        # Seeded at the nominal platform poses: a few Newton steps, and the same assembly branch for sure.
        return forward_kinematics(
            desc, nominal.joints[rows], params, seeds=nominal.platforms[rows], runtime=nominal.runtime
        )
    except UnreachablePose as exc:
        where = exc.data.get("pose", 0) if pose is None else pose
        raise UnreachablePose(
            f"with these tolerances the perturbed hexapod does not assemble at pose {where} "
            f"({'worst-case signs' if draw is None else f'draw {draw}'}): "
            f"{exc.detail}. The study is meant for manufacturing tolerances (tenths of a mm or degree); "
            "use smaller tolerances",
            pose=where,
            draw=draw,
            reason=str(exc.data.get("reason", "")),
        ) from exc


def _pose_errors(desc: RobotDescription, nominal: _Nominal, deltas: Array) -> PoseErrors:
    theta0 = desc.parameters.nominal
    exact = np.empty((deltas.shape[0], nominal.joints.shape[0], 6))
    for k, delta in enumerate(deltas):
        fk = _perturbed_fk(desc, nominal, theta0 + delta, draw=k)
        exact[k] = _pose_difference(fk.positions, fk.rotations, nominal.positions, nominal.rotations)
    first_order = np.einsum("nkp,dp->dnk", nominal.jacobians, deltas)
    return PoseErrors(exact, first_order)


def _carriage_frame_errors(desc: RobotDescription, nominal: _Nominal, deltas: Array) -> PoseErrors:
    """Errors of the carriage's own end frame {n} (the thesis's δX0, Figs. 31-32) for carriage-only deltas.

    First order without another Jacobian: with the hexapod untouched, frame {n}
    and the TCP move as one rigid body, so they share the rotation error dω and
    dp_frame = dp_tcp − dω × (p_tcp − p_frame).
    """
    fns = nominal.runtime.kinematics
    theta0 = desc.parameters.nominal
    q_chain = nominal.joints[:, : desc.n_chain]
    ref = nominal.carriage_frames
    exact = np.empty((deltas.shape[0], q_chain.shape[0], 6))
    for k, delta in enumerate(deltas):
        (frames,) = fns.batch("carriage_fk", q_chain, theta0 + delta)
        exact[k] = _pose_difference(frames[:, :3, 3], frames[:, :3, :3], ref[:, :3, 3], ref[:, :3, :3])
    tcp = np.einsum("nkp,dp->dnk", nominal.jacobians, deltas)
    lever = nominal.positions - ref[:, :3, 3]
    first_order = tcp.copy()
    first_order[..., :3] -= np.cross(tcp[..., 3:], lever[None, :, :])
    return PoseErrors(exact, first_order)


def pose_errors(desc: RobotDescription, joints: ArrayLike, deltas: ArrayLike) -> PoseErrors:
    """TCP errors at fixed joint readings caused by parameter errors `deltas` (D, n_params) or (n_params,).

    Joints (N, n_joints) in internal units; both models, see the module docstring.
    """
    q = as_joint_array(desc, joints)
    d = _deltas_array(desc, deltas)
    return _pose_errors(desc, _nominal(desc, q), d)


def carriage_frame_errors(desc: RobotDescription, joints: ArrayLike, deltas: ArrayLike) -> PoseErrors:
    """Errors of the carriage end frame {n} (world frame) caused by the carriage part of `deltas`."""
    q = as_joint_array(desc, joints)
    d = _deltas_array(desc, deltas) * subsystem_mask(desc, "carriage")
    return _carriage_frame_errors(desc, _nominal(desc, q), d)


def _deltas_array(desc: RobotDescription, deltas: ArrayLike) -> Array:
    d = np.atleast_2d(np.asarray(deltas, dtype=float))
    if d.ndim != 2 or d.shape[1] != desc.n_params:
        raise WrongShape(
            f"parameter errors must have {desc.n_params} numbers per draw, got shape {np.shape(deltas)}",
            field="deltas",
            expected=[-1, desc.n_params],
            got=list(np.shape(deltas)),
        )
    if not np.all(np.isfinite(d)):
        raise NonFiniteValue("parameter errors must be finite numbers", field="deltas")
    return d


def draw_errors(
    desc: RobotDescription, n_draws: int, tolerances: ErrorMagnitudes, distribution: str, rng: np.random.Generator
) -> Array:
    """(n_draws, n_params) parameter errors of the whole robot (carriage and hexapod), internal units.

    The random pattern does not depend on the tolerance values, so scaling the
    tolerances scales every draw by the same factor (what the linearisation
    test relies on).
    """
    _check_distribution(distribution)
    if distribution == "sign":
        # The thesis gives magnitudes: every parameter is off by exactly its tolerance, either way.
        pattern = 2.0 * rng.integers(0, 2, size=(n_draws, desc.n_params)) - 1.0
    else:
        pattern = rng.uniform(-1.0, 1.0, size=(n_draws, desc.n_params))
    return pattern * tolerances.vector(desc)


def subsystem_mask(desc: RobotDescription, subsystem: str) -> Array:
    """1.0 on the parameters whose errors a case switches on ("carriage", "hexapod", "whole"), else 0.0."""
    if subsystem not in SUBSYSTEMS:
        raise InvalidInput(f"unknown subsystem {subsystem!r}; use one of {list(SUBSYSTEMS)}", value=subsystem)
    mask = np.zeros(desc.n_params)
    for group in ("carriage", "hexapod") if subsystem == "whole" else (subsystem,):
        mask[desc.slices[group]] = 1.0
    return mask


def _worst_cases(desc: RobotDescription, nominal: _Nominal, tol: Array) -> dict[str, dict[str, WorstCase]]:
    """The first-order stack-up bound per case, quantity and axis, and the exact error at its signs."""
    theta0 = desc.parameters.nominal
    out: dict[str, dict[str, WorstCase]] = {}
    for sub in SUBSYSTEMS:
        t = tol * subsystem_mask(desc, sub)
        out[sub] = {}
        for quantity, rows in (("position", range(3)), ("orientation", range(3, 6))):
            bound, exact = np.zeros(3), np.zeros(3)
            for k, row in enumerate(rows):
                sens = nominal.jacobians[:, row, :]
                per_pose = np.abs(sens) @ t
                n = int(np.argmax(per_pose))
                delta = np.sign(sens[n]) * t
                fk = _perturbed_fk(desc, nominal, theta0 + delta, draw=None, pose=n)
                diff = _pose_difference(
                    fk.positions, fk.rotations, nominal.positions[n : n + 1], nominal.rotations[n : n + 1]
                )
                bound[k], exact[k] = per_pose[n], abs(diff[0, row])
            out[sub][quantity] = WorstCase(bound, exact)
    return out


def _check_distribution(distribution: str) -> None:
    if distribution not in DISTRIBUTIONS:
        raise InvalidInput(
            f"unknown error distribution {distribution!r}; use one of {list(DISTRIBUTIONS)}",
            field="distribution",
            value=str(distribution),
            allowed=list(DISTRIBUTIONS),
        )


def _check_count(name: str, value: int, limit: int) -> None:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= limit:
        raise InvalidInput(
            f"{name} = {value!r} must be a whole number between 1 and {limit}",
            field=name,
            value=str(value),
            min=1,
            max=limit,
        )


def error_analysis(
    desc: RobotDescription,
    *,
    n_poses: int = 40,
    n_draws: int = 200,
    tolerances: ErrorMagnitudes = ErrorMagnitudes(),
    distribution: str = "sign",
    seed: int = 0,
    runtime: Runtime | None = None,
) -> ErrorAnalysisResult:
    """The tolerance study: n_poses random workspace poses × n_draws error draws, three cases, two models.

    Poses are `sample_workspace(desc, n_poses, seed)`; the draws come from their
    own stream, so the same seed gives the same poses whatever `n_draws`.
    """
    _check_count("n_poses", n_poses, MAX_POSES)
    _check_count("n_draws", n_draws, MAX_DRAWS)
    if n_poses * n_draws > MAX_EVALUATIONS:
        raise InvalidInput(
            f"n_poses × n_draws = {n_poses * n_draws} exceeds {MAX_EVALUATIONS}; use fewer poses or draws",
            field="n_draws",
            value=n_poses * n_draws,
            max=MAX_EVALUATIONS,
        )
    _check_distribution(distribution)
    if not isinstance(tolerances, ErrorMagnitudes):
        raise InvalidInput("tolerances must be a ErrorMagnitudes value", field="tolerances")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InvalidInput(f"seed = {seed!r} must be a whole number >= 0", field="seed", value=str(seed))

    started = time.perf_counter()
    rt = runtime_for(desc, runtime)
    joints = sample_workspace(desc, n_poses, int(seed), runtime=rt)
    assert isinstance(joints, np.ndarray)
    nominal = _nominal(desc, joints, rt)
    deltas = draw_errors(desc, n_draws, tolerances, distribution, np.random.default_rng((int(seed), _DRAW_STREAM)))
    masks = {sub: subsystem_mask(desc, sub) for sub in SUBSYSTEMS}
    tol = tolerances.vector(desc)
    return ErrorAnalysisResult(
        robot=desc.name,
        tolerances=tolerances,
        distribution=distribution,
        seed=int(seed),
        joints=joints,
        joint_to_boundary=desc.joint_to_boundary,
        deltas=deltas,
        tolerance_vector=tol,
        masks=masks,
        jacobians=nominal.jacobians,
        errors={sub: _pose_errors(desc, nominal, deltas * masks[sub]) for sub in SUBSYSTEMS},
        carriage_frame=_carriage_frame_errors(desc, nominal, deltas * masks["carriage"]),
        worst_cases=_worst_cases(desc, nominal, tol),
        seconds=time.perf_counter() - started,
    )
