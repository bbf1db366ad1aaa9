"""The one factory of a process's robot runtimes: the API's lifespan and every job worker call it at start.

Each process owns its `models.Registry` (compiled Functions, solver pools, IK tables of every structure it
serves) and passes `runtime=registry.runtime(desc)` to every models call; nothing in the service falls back
to a process-wide registry (tests/service/test_registry.py forbids it).
"""

from __future__ import annotations

import logging
import os

from models import ModelTerms, Registry, iwr
from models.warm import warm_everything
from service.settings import Settings

log = logging.getLogger(__name__)

IWR_TERMS = (ModelTerms(thermal=True), ModelTerms(compliance=True), ModelTerms(thermal=True, compliance=True))
"""The IWR's structures with model terms (`options.terms`): their kinematics built at start-up too (their
inverse kinematics is the geometric structure's, `models.compensation.terms`)."""


def build_registry(settings: Settings) -> Registry:
    """A new registry for this process; with `settings.warm_up`, every artefact of the IWR built now, so no
    request (or job) pays for it. A helper forked from a forkserver that built them already (`preload`) takes
    that registry instead, when it was built under the environment this process has now."""
    if not settings.warm_up:
        return Registry()
    preloaded = _take_preloaded()
    return preloaded if preloaded is not None else _warmed()


def _warmed() -> Registry:
    registry = Registry()
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


_preloaded: tuple[dict[str, str], Registry] | None = None
"""The registry `preload` built in this process (a forkserver), and the environment it was built under; each
helper forked from it finds both in its copy of this module."""

_OWN_TO_EACH_TEST = "PYTEST_CURRENT_TEST"
"""The one variable that changes under a process without changing what a registry builds: pytest's name of the
running test."""


def preload() -> None:
    """Build the IWR's runtimes now, in this process, for the helpers it will fork (service.compute.processes:
    the forkserver imports service.compute.preload, which calls this). Each compute lane and job-pool process
    then starts with them built, copy-on-write, rather than building its own: ~0.9 s of CPU each, two or three
    per server start. Without warm-up in the environment, nothing is built; a failure is logged and each helper
    builds its own, as before."""
    global _preloaded  # noqa: PLW0603  (the forkserver's state, inherited by its forks)
    try:
        if not Settings().warm_up:
            return
        registry = _warmed()
    except Exception:  # the forkserver must serve whatever happens here (a bad setting too): helpers build their own
        log.exception("forkserver: the IWR's runtimes could not be built ahead; each helper builds its own")
        return
    _preloaded = (_environment(), registry)


def _take_preloaded() -> Registry | None:
    """The preloaded registry, once per process, if the environment is still the one it was built under (the
    native libraries' options and cache folder are read from it): a pool made after a setting changed builds
    its own."""
    global _preloaded  # noqa: PLW0603
    if _preloaded is None:
        return None
    environment, registry = _preloaded
    _preloaded = None
    return registry if environment == _environment() else None


def _environment() -> dict[str, str]:
    return {name: value for name, value in os.environ.items() if name != _OWN_TO_EACH_TEST}
