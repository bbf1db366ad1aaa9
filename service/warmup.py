"""Build every CasADi Function and solver once, at start-up, so no request pays for it."""

from __future__ import annotations

from models import default_registry, iwr
from models.warm import warm_everything


def warm_up() -> None:
    warm_everything(default_registry(), iwr())
