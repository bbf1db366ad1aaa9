"""Array and pose types shared by every module of `models` (internal units: mm, rad)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]
"""A float array; each use documents its shape and units."""
Vec3 = tuple[float, float, float]
Pose6 = tuple[float, float, float, float, float, float]
"""x, y, z (mm) and a rotation vector or Euler angles (rad), as the field using it says."""
IDENTITY: Pose6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def finite_or_none(x: float | None) -> float | None:
    """JSON has no NaN: a missing or non-finite number becomes None (null)."""
    return None if x is None or not np.isfinite(x) else float(x)


def first_nonfinite_record(a: Array) -> int | None:
    """The first record (a row; an element of a 1-d array) holding a NaN or an infinity; None when none does."""
    bad = np.argwhere(~np.isfinite(a))
    return int(bad[0][0]) if bad.size else None
