"""Random poses inside the workspace of the spec, seeded and reproducible.

Serial joints are drawn uniformly in their ranges and the platform pose
uniformly in the hexapod's workspace box; the legs follow from the nominal
closed-form inverse kinematics. Poses whose legs leave their strokes or whose
hexapod is near a singularity are rejected and redrawn.
"""

from __future__ import annotations

from typing import Literal, overload

import numpy as np

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput

_MAX_ROUNDS = 50


@overload
def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: Literal[False] = False,
    runtime: Runtime | None = None,
) -> Array: ...


@overload
def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: Literal[True],
    runtime: Runtime | None = None,
) -> tuple[Array, Array]: ...


def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: bool = False,
    runtime: Runtime | None = None,
) -> Array | tuple[Array, Array]:
    """n joint vectors (n, n_joints), internal units; optionally also their platform poses (n, 6)."""
    if n < 0:
        raise InvalidInput(f"the number of poses must be non-negative, got {n}", field="n", value=n, min=0)
    if runtime is not None:
        runtime_for(desc, runtime)  # a runtime given is checked against desc, though sampling needs none
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    theta = desc.parameters.nominal if params is None else params
    if not desc.has_closure:
        # Serial joints alone: uniform in their ranges, every draw valid.
        lo, hi = desc.joint_min, desc.joint_max
        q = lo + rng.random((n, desc.n_chain)) * (hi - lo)
        return (q, np.zeros((n, desc.n_platform))) if return_platforms else q
    # The serial joints uniform in their ranges, the closures' unknowns uniform in their workspace; each
    # parallel stage's legs by its inverse kinematics, kept where every stage is usable.
    lo_w, hi_w = desc.platform_limits
    lo_c, hi_c = desc.joint_min[: desc.n_chain], desc.joint_max[: desc.n_chain]
    joints: list[Array] = []
    platforms: list[Array] = []
    have = 0
    for _ in range(_MAX_ROUNDS):
        if have >= n:
            break
        m = max(16, int(1.3 * (n - have)))
        q = np.empty((m, desc.n_joints))
        q[:, : desc.n_chain] = lo_c + rng.random((m, desc.n_chain)) * (hi_c - lo_c)
        plat = lo_w + rng.random((m, desc.n_unknowns)) * (hi_w - lo_w)
        ok = np.ones(m, dtype=bool)
        for stage, at in zip(desc.stages, desc.placements, strict=True):
            if stage.n_unknowns:
                q[:, at.joints] = stage.joints_of_unknowns(plat[:, at.unknowns], theta[at.params])
            ok &= stage.usable(q[:, at.joints], plat[:, at.unknowns], theta[at.params])
        joints.append(q[ok])
        platforms.append(plat[ok])
        have += int(ok.sum())
    q = np.vstack(joints)[:n] if joints else np.empty((0, desc.n_joints))
    x = np.vstack(platforms)[:n] if platforms else np.empty((0, desc.n_platform))
    if q.shape[0] < n:
        raise InvalidInput(
            "the workspace description admits almost no pose: check strokes and ranges", field="workspace"
        )
    return (q, x) if return_platforms else q


def workspace_samples(desc: RobotDescription, n: int, seed: int, *, runtime: Runtime | None = None) -> Array:
    """`sample_workspace(desc, n, seed)`, drawn once per description and kept by the runtime (read-only).

    For the fixed sample sets of the pipelines (structural identifiability, predicted accuracy, design's task
    matrix): the same poses every call, so drawing them again would only cost time.
    """
    rt = runtime_for(desc, runtime)

    def draw() -> Array:
        joints = sample_workspace(desc, n, seed, runtime=rt)
        joints.setflags(write=False)
        return joints

    return rt.artefact("workspace_samples", (desc, n, seed), draw, capacity=32)
