"""Unit conversions between internal (mm, rad) and boundary (mm, deg) numbers: the schemas' domain defaults and the
instrument's σ a request states."""

from __future__ import annotations

import math

from models.noise import NoiseModel


def degrees_default(radians: float) -> float:
    """A domain default in radians as the boundary's degrees, without the last-bit noise of the round trip
    (0.01° stored as radians must read back as 0.01, not 0.009999999999999998)."""
    return float(f"{math.degrees(radians):.12g}")


def instrument_noise(position_mm: float, orientation_deg: float) -> NoiseModel:
    """The instrument's σ as a request states it (mm, degrees), in internal units: the one place every operation
    (calibrations, checks, designs, adaptive campaigns, trees) turns it into the models' NoiseModel."""
    return NoiseModel(position_mm, math.radians(orientation_deg))
