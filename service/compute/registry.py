"""The one factory of a process's robot runtimes: the API's lifespan and every job worker call it at start.

Each process owns its `models.Registry` (compiled Functions, solver pools, IK tables of every structure it
serves) and passes `runtime=registry.runtime(desc)` to every models call; nothing in the service falls back
to a process-wide registry (tests/service/test_registry.py forbids it).
"""

from __future__ import annotations

from models import ModelTerms, Registry, iwr
from models.warm import warm_everything
from service.settings import Settings

IWR_TERMS = (ModelTerms(thermal=True), ModelTerms(compliance=True), ModelTerms(thermal=True, compliance=True))
"""The IWR's structures with model terms (`options.terms`): their kinematics built at start-up too (their
inverse kinematics is the geometric structure's, `models.compensation.terms`)."""


def build_registry(settings: Settings) -> Registry:
    """A new registry for this process; with `settings.warm_up`, every artefact of the IWR built now, so no
    request (or job) pays for it."""
    registry = Registry()
    if settings.warm_up:
        warm_everything(registry, iwr())
        for terms in IWR_TERMS:
            registry.warm(iwr().with_terms(terms))
    return registry


def native_functions(registry: Registry) -> bool:
    """Whether this process evaluates the IWR's batch Functions from a compiled library (`External`), not in
    CasADi's virtual machine (a runtime image without its prebuilt library falls back, ~2x slower, with a
    warning and `iwr_vm_only_structures_total`; see models.engine.native)."""
    native = registry.runtime(iwr()).kinematics.native
    return bool(native) and all(f.class_name() == "External" for f in native.values())
