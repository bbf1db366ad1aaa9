"""Build every CasADi Function and solver once, at start-up, so no request pays for it."""

from __future__ import annotations

from models import default_registry, iwr
from models.warm import warm_everything


def warm_up() -> None:
    warm_everything(default_registry(), iwr())


def native_functions() -> bool:
    """Whether this process evaluates the IWR's batch Functions from a compiled library (`External`), not in
    CasADi's virtual machine (a runtime image without its prebuilt library falls back, ~2x slower, with a
    warning and `iwr_vm_only_structures_total`; see models.native)."""
    native = default_registry().runtime(iwr()).kinematics.native
    return bool(native) and all(f.class_name() == "External" for f in native.values())
