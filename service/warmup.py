"""Build every CasADi Function and solver once, at start-up, so no request pays for it."""

from __future__ import annotations

from models import default_registry, iwr


def warm_up() -> None:
    default_registry().warm(iwr())
