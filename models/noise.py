"""Instrument noise: the σ every residual is divided by."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NoiseModel:
    """Instrument noise, internal units: σ position (mm) and σ orientation (rad)."""

    position_mm: float = 0.025
    orientation_rad: float = float(np.radians(0.01))
