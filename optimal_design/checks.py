"""Poses for a quick check (models.evaluation.checks): the few whose records see the likely changes best.

The likely changes are the *watched* parameters — by default each joint offset (`…theta`, a leg's `…offset`),
the tool and, for a check without registration, the base. A candidate pose contributes its σ-weighted rows on
those parameters (each column times the parameter's tolerance, so a tolerance of each counts alike) beside the
registration's six columns, a nuisance. The design maximises the Bayesian Dₛ criterion

    log det(I + M_ww − M_wg M_gg⁻¹ M_gw)

(the information on the watched parameters left after the instrument frame is fitted, with a prior of one
tolerance, so that 8 poses give a finite value for more watched parameters than rows): a greedy start, then
exchanges of one pose at a time while one improves it. Candidates are workspace samples (or given).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models import NoiseModel, RobotDescription, forward_kinematics
from models._types import Array
from models.description.parameters import Kind
from models.engine.blas import single_threaded_blas
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput
from models.evaluation.checks import CheckOptions, detectable_changes, frame_columns
from models.workspace import sample_workspace

MIN_CHECK_POSES = 3
MAX_CHECK_POSES = 30
EXCHANGE_PASSES = 20
NUISANCE_RIDGE = 1e-9
"""Relative ridge on the registration's information: a set of fewer than three poses does not fix the frame."""


@dataclass(frozen=True)
class CheckDesign:
    joints: Array
    """(count, n_joints) the chosen poses, internal units."""
    watched: tuple[int, ...]
    """Table indices of the parameters the design watches."""
    value: float
    """The criterion at the design."""
    detectable: Array
    """For each watched parameter, the change of it alone the check flags with 95 % probability (internal)."""
    candidates: int


def watched_parameters(desc: RobotDescription, *, register: bool) -> tuple[int, ...]:
    """The joint offsets, the tool, and the base where the check fixes no frame of its own.

    A joint offset is `link{k}.d` for a prismatic k-th joint, `link{k}.theta` for a revolute one (robots.md's
    link numbering), and each leg's `…offset`."""
    table = desc.parameters
    serial = [f"link{k + 1}.{'d' if kind is Kind.LENGTH else 'theta'}" for k, kind in enumerate(desc.joint_kinds)]
    offsets = [table.index[n] for n in serial if n in table.index]
    offsets += [i for i, n in enumerate(table.names) if n.endswith(".offset")]
    groups = ("tool",) if register else ("tool", "base")
    return tuple(sorted(set(offsets) | set(table.indices(groups))))


@single_threaded_blas
def design_check(
    desc: RobotDescription,
    params: Array,
    count: int = 8,
    *,
    covariance: Array | None = None,
    watched: tuple[int, ...] | None = None,
    position_only: bool = True,
    candidates: Array | None = None,
    candidate_count: int = 500,
    seed: int = 0,
    noise: NoiseModel | None = None,
    options: CheckOptions | None = None,
    runtime: Runtime | None = None,
) -> CheckDesign:
    """`count` check poses of the version `params` (covariance: its parameters', for the detectable changes)."""
    if not MIN_CHECK_POSES <= count <= MAX_CHECK_POSES:
        raise InvalidInput(
            f"a check has {MIN_CHECK_POSES} to {MAX_CHECK_POSES} poses, asked {count}",
            field="count",
            min=MIN_CHECK_POSES,
            max=MAX_CHECK_POSES,
        )
    options, noise = options or CheckOptions(), noise or NoiseModel()
    rt = runtime_for(desc, runtime)
    pool = sample_workspace(desc, candidate_count, seed=seed) if candidates is None else np.asarray(candidates)
    if pool.shape[0] < count:
        raise InvalidInput(f"{pool.shape[0]} candidates cannot give {count} poses", field="candidate_count")
    chosen_params = watched if watched is not None else watched_parameters(desc, register=options.register)
    blocks = _blocks(
        desc,
        params,
        pool,
        chosen_params,
        position_only=position_only,
        noise=noise,
        register=options.register,
        runtime=rt,
    )
    index, value = _exchange(blocks, len(chosen_params), count)
    joints = pool[index]
    cov = np.zeros((desc.n_params, desc.n_params)) if covariance is None else covariance
    detectable = detectable_changes(
        desc, params, cov, joints, chosen_params, position_only=position_only, noise=noise, options=options, runtime=rt
    )
    return CheckDesign(joints, chosen_params, value, detectable, int(pool.shape[0]))


def _blocks(
    desc: RobotDescription,
    params: Array,
    pool: Array,
    watched: tuple[int, ...],
    *,
    position_only: bool,
    noise: NoiseModel,
    register: bool,
    runtime: Runtime,
) -> Array:
    """(M, rows, k + g) each candidate's weighted rows: watched columns times tolerances, then the frame's."""
    fk = forward_kinematics(desc, pool, params, jacobian=True, runtime=runtime)
    rows = 3 if position_only else 6
    sigma = np.array([noise.position_mm] * 3 + [noise.orientation_rad] * 3)[:rows]
    watch = fk.jacobians[:, :rows][:, :, list(watched)] * desc.parameters.scales[list(watched)]
    # Centred: the frame's information is the same up to an invertible change of its unknowns, and better scaled.
    frame = frame_columns(fk.positions - fk.positions.mean(axis=0))[:, :rows]
    parts = [watch, frame] if register else [watch]
    return np.asarray(np.concatenate(parts, axis=2) / sigma[None, :, None], dtype=float)


def _criterion(m: Array, k: int) -> Array:
    """log det(I + Schur complement) over a batch of (…, k + g, k + g) information matrices."""
    mww, mwg, mgg = m[..., :k, :k], m[..., :k, k:], m[..., k:, k:]
    if mgg.shape[-1]:
        ridge = NUISANCE_RIDGE * np.trace(mgg, axis1=-2, axis2=-1)[..., None, None] + 1e-300
        mgg = mgg + ridge * np.eye(mgg.shape[-1])
        mww = mww - mwg @ np.linalg.solve(mgg, np.swapaxes(mwg, -1, -2))
    return np.asarray(np.linalg.slogdet(np.eye(k) + mww)[1], dtype=float)


def _exchange(blocks: Array, k: int, count: int) -> tuple[list[int], float]:
    """Greedy additions, then the best single exchange while one improves the criterion."""
    grams = np.einsum("mri,mrj->mij", blocks, blocks)
    chosen: list[int] = []
    total = np.zeros(grams.shape[1:])
    for _ in range(count):
        values = _criterion(total + grams, k)
        values[chosen] = -np.inf
        best = int(np.argmax(values))
        chosen.append(best)
        total = total + grams[best]
    value = float(_criterion(total, k))
    for _ in range(EXCHANGE_PASSES):
        improved = False
        for slot in range(count):
            without = total - grams[chosen[slot]]
            values = _criterion(without + grams, k)
            values[chosen] = -np.inf
            best = int(np.argmax(values))
            if values[best] > value * (1 + 1e-9) + 1e-12:
                chosen[slot], total, value, improved = best, without + grams[best], float(values[best]), True
        if not improved:
            break
    return chosen, value
