"""A target's declared configuration against the joints: the seed that asks the nominal solution for it, and
whether the nominal and the compensated solutions keep it (a controller that follows the declared status,
turn or confdata would otherwise drive another solution than the compensated one)."""

from __future__ import annotations

import numpy as np

from models._types import Array
from programs.targets import Configuration

QUARTER = np.pi / 2


def _values(config: Configuration, q: Array) -> tuple[int, ...]:
    picked = q[list(config.joints)]
    if config.kind == "sign":
        return tuple(int(v < 0) for v in picked)
    return tuple(int(np.floor(v / QUARTER)) for v in picked)


def seed(config: Configuration | None, base: Array, n_joints: int) -> Array:
    """`base` moved into the declared configuration: each named joint to the middle of its quarter turn, or
    to the declared side of zero."""
    out = np.array(base, dtype=float)
    if config is None or max(config.joints) >= n_joints:
        return out
    for joint, value in zip(config.joints, config.values, strict=True):
        if config.kind == "quadrant":
            out[joint] = (value + 0.5) * QUARTER
        elif (out[joint] < 0) != bool(value):
            out[joint] = -out[joint] if out[joint] != 0 else (-0.25 if value else 0.25)
    return out


def kept(config: Configuration | None, nominal: Array, compensated: Array, names: tuple[str, ...]) -> str | None:
    """Why the target keeps its value for its configuration (None: the configuration holds)."""
    if config is None or max(config.joints) >= nominal.size or not np.isfinite(nominal).all():
        return None
    if _values(config, nominal) != config.values:
        return (
            f"the nominal robot reaches it only in another configuration than the program's {config.text} "
            f"(the nearest nominal solution has {_values(config, nominal)})"
        )
    if np.isfinite(compensated).all() and _values(config, compensated) != config.values:
        moved = [
            names[j]
            for j, a, b in zip(config.joints, _values(config, nominal), _values(config, compensated), strict=True)
            if a != b
        ]
        return (
            f"a configuration flip: the compensated solution moves {', '.join(moved)} across a boundary of "
            f"{config.text}, which the controller would not follow"
        )
    return None
