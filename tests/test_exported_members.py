"""Each package's public surface is its `__all__`: complete, and nothing else public at the top."""

from __future__ import annotations

import importlib
import types

import pytest

import models

PACKAGES = ["models", "models.identification", "models.compensation", "models.inverse", "optimal_design", "iwr_client"]


@pytest.mark.parametrize("name", PACKAGES)
def test_all_is_the_public_surface(name: str) -> None:
    package = importlib.import_module(name)
    exported = list(package.__all__)  # (kept sorted by ruff's RUF022)
    public = {
        member
        for member, value in vars(package).items()
        if not member.startswith("_") and not isinstance(value, types.ModuleType) and member != "annotations"
    }
    assert set(exported) == public


def test_internals_stay_internal() -> None:

    for internal in ("FUNCTIONS", "functions_for", "RobotFunctions", "Tolerances"):
        assert not hasattr(models, internal), internal
