"""Per-candidate information, on the same scaled Jacobian and identifiable subset as the identification.

A candidate pose contributes the block `Aᵢ` (rows: its measured coordinates
divided by the instrument σ; columns: the identifiable parameters times their
tolerance): exactly the rows identification would stack for it
(`models.identifiability.scaled_jacobian`), restricted to the subset
identification would estimate (`structural_identifiability`). The information
of a design is `M = Σ AᵢᵀAᵢ`; its inverse is the covariance of the estimate in
tolerance units.

`L` (`task`) turns that covariance into what the user cares about: the mean
predicted TCP position variance over random workspace poses, `trace(L M⁻¹)`
(mm²).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from models import NoiseModel, RobotDescription, forward_kinematics, scaled_jacobian
from models._types import Array
from models.description.terms import Conditions
from models.engine.runtime import Runtime, runtime_for
from models.identifiability import analyse_identifiability, measurement_rows, structural_support
from models.measurement import MeasurementKind
from models.workspace import workspace_samples

WORKSPACE_POSES = 400
WORKSPACE_SEED = 20_091_231
CHUNK_ROWS = 100_000


@dataclass(frozen=True)
class CandidateInformation:
    joints: Array
    """(M, n_joints) internal units."""
    blocks: Array
    """(M, rows, P) scaled rows of each candidate on the identifiable parameters."""
    free: tuple[int, ...]
    """Identifiable parameters (table indices), in column order."""
    task: Array
    """(P, P) `L`: mean TCP position sensitivity over the workspace, so that trace(L M⁻¹) is in mm²."""
    position_only: bool
    task_rows: Array | None = None
    """(N, 3, P) the scaled TCP position rows at each workspace pose behind `task` (task = mean of their Gram)."""
    conditions: Conditions | None = None
    """Each candidate's conditions (temperature, payload) where the model has terms: their columns need them."""

    @property
    def size(self) -> int:
        return int(self.blocks.shape[0])

    @property
    def n_params(self) -> int:
        return int(self.blocks.shape[2])

    @property
    def rows(self) -> int:
        return int(self.blocks.shape[1])

    def information(self, weights: Array, index: NDArray[Any] | None = None) -> Array:
        """M(w) = Σ wᵢ AᵢᵀAᵢ (over `index` only, `weights` then aligned with it)."""
        blocks = self.blocks if index is None else self.blocks[index]
        a = blocks * np.sqrt(np.maximum(weights, 0.0))[:, None, None]
        flat = a.reshape(-1, self.n_params)
        return np.asarray(flat.T @ flat, dtype=float)

    def quadratic(self, q: NDArray[Any], index: NDArray[Any] | None = None) -> Array:
        """tr(Q AᵢᵀAᵢ) = Σ_rows aᵣᵀ Q aᵣ for every candidate (or those of `index`), in chunks.

        One (chunk·rows × P) @ (P × P) product then a row-wise dot: the form that uses BLAS 3 and keeps the
        temporary at CHUNK rows (40 MB at P = 54) whatever M is."""
        blocks = self.blocks if index is None else self.blocks[index]
        flat = blocks.reshape(-1, self.n_params)
        out = np.empty(flat.shape[0])
        step = CHUNK_ROWS
        for lo in range(0, flat.shape[0], step):
            part = flat[lo : lo + step]
            out[lo : lo + step] = np.einsum("ij,ij->i", part @ q, part)
        return np.asarray(out.reshape(blocks.shape[0], self.rows).sum(axis=1), dtype=float)

    def subset_information(self, index: NDArray[Any]) -> Array:
        flat = self.blocks[index].reshape(-1, self.n_params)
        return np.asarray(flat.T @ flat, dtype=float)


def candidate_information(
    desc: RobotDescription,
    joints: Array,
    *,
    position_only: bool,
    noise: NoiseModel | None = None,
    params: Array | None = None,
    runtime: Runtime | None = None,
    conditions: Conditions | None = None,
) -> CandidateInformation:
    """With model terms on, `conditions` (one per candidate) give the terms' columns: a κ column is zero at the
    reference temperature, so only candidates at spread temperatures (loads) inform it."""
    rt = runtime_for(desc, runtime)
    noise = noise or NoiseModel()
    table = desc.parameters
    kind = MeasurementKind.of(position_only)
    fk = forward_kinematics(desc, joints, params, jacobian=True, runtime=rt, conditions=conditions)
    scaled = scaled_jacobian(fk.jacobians, table, noise, kind=kind)
    everything = tuple(range(len(table)))
    support = structural_support(desc, scaled, everything, kind, runtime=rt)
    free = support.structural.identifiable if support.supported else analyse_identifiability(scaled, table).identifiable
    rows = measurement_rows(position_only)
    # C order: indexing the free columns leaves the parameter axis outermost (strides (48, 8, 8·rows·M)), which
    # made every product of the blocks with a P × P matrix (greedy, gradients, swap terms) twice as slow and
    # every gather of candidates three times.
    blocks = np.ascontiguousarray(scaled.reshape(joints.shape[0], rows, len(table))[:, :, list(free)])
    return CandidateInformation(
        joints=np.asarray(joints, dtype=float),
        blocks=blocks,
        free=tuple(free),
        task=task_matrix(desc, tuple(free), runtime=rt),
        position_only=position_only,
        task_rows=task_rows(desc, tuple(free), runtime=rt),
        conditions=conditions if desc.terms.any else None,
    )


def task_rows(desc: RobotDescription, free: tuple[int, ...], *, runtime: Runtime | None = None) -> Array:
    """(N, 3, P) S Jₚ at the workspace poses: Jₚ the TCP position rows, S the parameter tolerances.

    Kept by the structure's runtime, per description and subset.
    """
    rt = runtime_for(desc, runtime)

    def build() -> Array:
        joints = workspace_samples(desc, WORKSPACE_POSES, WORKSPACE_SEED, runtime=rt)
        jac = forward_kinematics(desc, joints, jacobian=True, runtime=rt).jacobians
        scales = desc.parameters.scales[list(free)]
        rows = np.asarray(jac[:, :3, :][:, :, list(free)] * scales[None, None, :])
        rows.setflags(write=False)
        return rows

    return rt.artefact("task_rows", (desc, free), build, capacity=16)


def task_matrix(desc: RobotDescription, free: tuple[int, ...], *, runtime: Runtime | None = None) -> Array:
    """L = mean over workspace poses of (S Jₚ)ᵀ (S Jₚ), so that trace(L M⁻¹) is the mean TCP variance (mm²)."""
    rt = runtime_for(desc, runtime)

    def build() -> Array:
        jp = task_rows(desc, free, runtime=rt)
        flat = jp.reshape(-1, len(free))
        return np.asarray((flat.T @ flat) / jp.shape[0])

    return rt.artefact("task_matrix", (desc, free), build, capacity=16)


def max_tcp_error(rows: Array, m: Array) -> float:
    """Predicted TCP position error (mm, root of the 3-D variance) at the worst workspace pose: max_p tr(Jₚ M⁻¹ Jₚᵀ)."""
    try:
        inv = np.linalg.inv(m)
    except np.linalg.LinAlgError:
        return float("inf")
    per_pose = np.einsum("pri,ij,prj->p", rows, inv, rows, optimize=True)
    return float(np.sqrt(max(float(per_pose.max()), 0.0)))
