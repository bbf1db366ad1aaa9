"""Build every CasADi Function and solver once, at start-up, so no request pays for it."""

from __future__ import annotations

from models import ModelTerms, default_registry, iwr
from models.warm import warm_everything

IWR_TERMS = (ModelTerms(thermal=True), ModelTerms(compliance=True), ModelTerms(thermal=True, compliance=True))
"""The IWR's structures with model terms (`options.terms`): their kinematics built at start-up too (their
inverse kinematics is the geometric structure's, `models.compensation.terms`)."""


def warm_up() -> None:
    registry = default_registry()
    warm_everything(registry, iwr())
    for terms in IWR_TERMS:
        registry.warm(iwr().with_terms(terms))


def native_functions() -> bool:
    """Whether this process evaluates the IWR's batch Functions from a compiled library (`External`), not in
    CasADi's virtual machine (a runtime image without its prebuilt library falls back silently, ~2x slower)."""
    native = default_registry().runtime(iwr()).kinematics.native
    return bool(native) and all(f.class_name() == "External" for f in native.values())
