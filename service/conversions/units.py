"""Unit factors between internal (mm, rad) and boundary (mm, deg) numbers, for the schemas' domain defaults."""

from __future__ import annotations

import math


def degrees_default(radians: float) -> float:
    """A domain default in radians as the boundary's degrees, without the last-bit noise of the round trip
    (0.01° stored as radians must read back as 0.01, not 0.009999999999999998)."""
    return float(f"{math.degrees(radians):.12g}")
