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
from models.identifiability import analyse_identifiability, measurement_rows, structural_support
from models.kinematics import Array
from models.measurement import MeasurementKind
from models.runtime import Runtime, runtime_for
from models.workspace import workspace_samples

WORKSPACE_POSES = 400
WORKSPACE_SEED = 20_091_231


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

    @property
    def size(self) -> int:
        return int(self.blocks.shape[0])

    @property
    def n_params(self) -> int:
        return int(self.blocks.shape[2])

    @property
    def rows(self) -> int:
        return int(self.blocks.shape[1])

    def information(self, weights: Array) -> Array:
        """M(w) = Σ wᵢ AᵢᵀAᵢ."""
        a = self.blocks * np.sqrt(np.maximum(weights, 0.0))[:, None, None]
        flat = a.reshape(-1, self.n_params)
        return flat.T @ flat

    def subset_information(self, index: NDArray[Any]) -> Array:
        flat = self.blocks[index].reshape(-1, self.n_params)
        return flat.T @ flat


def candidate_information(
    desc: RobotDescription,
    joints: Array,
    *,
    position_only: bool,
    noise: NoiseModel | None = None,
    params: Array | None = None,
    runtime: Runtime | None = None,
) -> CandidateInformation:
    rt = runtime_for(desc, runtime)
    noise = noise or NoiseModel()
    table = desc.parameters
    kind = MeasurementKind.of(position_only)
    fk = forward_kinematics(desc, joints, params, jacobian=True, runtime=rt)
    scaled = scaled_jacobian(fk.jacobians, table, noise, kind=kind)
    everything = tuple(range(len(table)))
    support = structural_support(desc, scaled, everything, kind, runtime=rt)
    free = support.structural.identifiable if support.supported else analyse_identifiability(scaled, table).identifiable
    rows = measurement_rows(position_only)
    blocks = scaled.reshape(joints.shape[0], rows, len(table))[:, :, list(free)]
    return CandidateInformation(
        joints=np.asarray(joints, dtype=float),
        blocks=blocks,
        free=tuple(free),
        task=task_matrix(desc, tuple(free), runtime=rt),
        position_only=position_only,
    )


def task_matrix(desc: RobotDescription, free: tuple[int, ...], *, runtime: Runtime | None = None) -> Array:
    """L = mean over workspace poses of (S Jₚ)ᵀ (S Jₚ): Jₚ the TCP position rows, S the parameter tolerances.

    Kept by the structure's runtime, per description and subset.
    """
    rt = runtime_for(desc, runtime)

    def build() -> Array:
        joints = workspace_samples(desc, WORKSPACE_POSES, WORKSPACE_SEED, runtime=rt)
        jac = forward_kinematics(desc, joints, jacobian=True, runtime=rt).jacobians
        scales = desc.parameters.scales[list(free)]
        jp = jac[:, :3, :][:, :, list(free)] * scales[None, None, :]
        flat = jp.reshape(-1, len(free))
        return (flat.T @ flat) / joints.shape[0]

    return rt.artefact("task_matrix", (desc, free), build, capacity=16)
