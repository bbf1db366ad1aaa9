"""Everything a request may need, built ahead of time: the kinematics, inverse kinematics and identification.

The core's `Registry.warm` builds only what it owns; this module, above both layers, passes their warmers in, so
the core imports neither (import-linter keeps it so).
"""

from __future__ import annotations

from models.description.robot import RobotDescription
from models.engine.runtime import Registry, Warmer
from models.identification.warm import warm_identification
from models.inverse.warm import warm_inverse

WARMERS: tuple[Warmer, ...] = (warm_inverse, warm_identification)


def warm_everything(registry: Registry, desc: RobotDescription) -> float:
    """Build every artefact of `desc`'s structure in `registry`; the seconds it took (≈0 when already warm)."""
    return registry.warm(desc, WARMERS)
