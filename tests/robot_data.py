"""Real robots' descriptions from a public package: example-robot-data (BSD-3-Clause, a dev dependency), whose
wheel installs its URDFs under `<site-packages>/cmeel.prefix/share/example-robot-data/robots`. Tests that read
one skip, naming the package, where it is not installed."""

from __future__ import annotations

import sysconfig
from pathlib import Path

import pytest

ROBOTS = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"


def robot_file(relative: str) -> Path:
    """The file at `relative` under the package's robots folder (`tiago_description/robots/tiago.urdf`); the
    calling test is skipped when the package is missing."""
    path = ROBOTS / relative
    if not path.is_file():
        pytest.skip(f"example-robot-data is not installed ({path} missing): `make install` installs it")
    return path
