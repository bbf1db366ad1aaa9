"""Random poses inside the workspace of the spec, seeded and reproducible.

Serial joints are drawn uniformly in their ranges and the platform pose
uniformly in the hexapod's workspace box; the legs follow from the nominal
closed-form inverse kinematics. Poses whose legs leave their strokes or whose
hexapod is near a singularity are rejected and redrawn.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Literal, overload

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput

DRAW_ROUNDS = 50
"""Batches drawn in search of usable poses (a leg in its stroke, away from a singularity) before giving up."""

UsableDraw = Callable[[int], tuple[NDArray[np.bool_], tuple[Array, ...]]]
"""`m` rows drawn at once: which of them are usable, and the arrays (m rows each) they are rows of."""


def usable_draws(n: int, draw: UsableDraw, widths: tuple[int, ...]) -> tuple[Array, ...] | None:
    """The first `n` usable rows of each array `draw` gives, drawn in batches sized to what is still missing (a
    third more, at least 16); None when `DRAW_ROUNDS` batches do not give `n` (a workspace that admits almost no
    pose). `widths`: each array's columns (what `n` = 0 gives, nothing drawn)."""
    kept: list[tuple[Array, ...]] = []
    have = 0
    for _ in range(DRAW_ROUNDS):
        if have >= n:
            break
        ok, arrays = draw(max(16, int(1.3 * (n - have))))
        kept.append(tuple(a[ok] for a in arrays))
        have += int(ok.sum())
    if have < n:
        return None
    if not kept:
        return tuple(np.empty((0, width)) for width in widths)
    return tuple(np.vstack(column)[:n] for column in zip(*kept, strict=True))


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

    def draw(m: int) -> tuple[NDArray[np.bool_], tuple[Array, ...]]:
        q = np.empty((m, desc.n_joints))
        q[:, : desc.n_chain] = lo_c + rng.random((m, desc.n_chain)) * (hi_c - lo_c)
        plat = lo_w + rng.random((m, desc.n_unknowns)) * (hi_w - lo_w)
        ok = np.ones(m, dtype=bool)
        for stage, at in zip(desc.stages, desc.placements, strict=True):
            if stage.n_unknowns:
                q[:, at.joints] = stage.joints_of_unknowns(plat[:, at.unknowns], theta[at.params])
            ok &= stage.usable(q[:, at.joints], plat[:, at.unknowns], theta[at.params])
        return ok, (q, plat)

    drawn = usable_draws(n, draw, (desc.n_joints, desc.n_platform))
    if drawn is None:
        raise InvalidInput(
            "the workspace description admits almost no pose: check strokes and ranges", field="workspace"
        )
    q, x = drawn
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
