"""Shared fixtures: the IWR description and simulated robots with known errors."""

from __future__ import annotations

import numpy as np
import pytest

from models import RobotDescription, iwr


@pytest.fixture(scope="session")
def desc() -> RobotDescription:
    return iwr()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
