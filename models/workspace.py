"""Random poses inside the workspace of the spec, seeded and reproducible.

Chain joints are drawn uniformly in their ranges and the platform pose
uniformly in the hexapod's workspace box; the legs follow from the nominal
closed-form inverse kinematics. Poses whose legs leave their strokes or whose
hexapod is near a singularity are rejected and redrawn.
"""

from __future__ import annotations

from typing import Literal, overload

import numpy as np

from models.hybrid import RobotDescription
from models.kinematics import Array, hexapod_condition, inverse_hexapod

_MAX_ROUNDS = 50


@overload
def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: Literal[False] = False,
) -> Array: ...


@overload
def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: Literal[True],
) -> tuple[Array, Array]: ...


def sample_workspace(
    desc: RobotDescription,
    n: int,
    seed: int | np.random.Generator | None = 0,
    params: Array | None = None,
    *,
    return_platforms: bool = False,
) -> Array | tuple[Array, Array]:
    """n joint vectors (n, n_joints), internal units; optionally also their platform poses (n, 6)."""
    if n < 0:
        raise ValueError("n must be non-negative")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    theta = desc.parameters.nominal if params is None else params
    lo_w, hi_w = np.array(desc.hexapod.workspace_min), np.array(desc.hexapod.workspace_max)
    lo_c, hi_c = desc.joint_min[: desc.n_chain], desc.joint_max[: desc.n_chain]
    joints: list[Array] = []
    platforms: list[Array] = []
    have = 0
    for _ in range(_MAX_ROUNDS):
        if have >= n:
            break
        m = max(16, int(1.3 * (n - have)))
        chain = lo_c + rng.random((m, desc.n_chain)) * (hi_c - lo_c)
        plat = lo_w + rng.random((m, 6)) * (hi_w - lo_w)
        legs = inverse_hexapod(desc, plat, theta)
        ok = np.all((legs >= desc.hexapod.stroke_min) & (legs <= desc.hexapod.stroke_max), axis=1)
        ok &= hexapod_condition(desc, plat, theta) <= desc.hexapod.max_condition
        joints.append(np.hstack([chain, legs])[ok])
        platforms.append(plat[ok])
        have += int(ok.sum())
    q = np.vstack(joints)[:n] if joints else np.empty((0, desc.n_joints))
    x = np.vstack(platforms)[:n] if platforms else np.empty((0, 6))
    if q.shape[0] < n:
        raise RuntimeError("the workspace description admits almost no pose: check strokes and ranges")
    return (q, x) if return_platforms else q
