"""Imported by the forkserver of the helper processes (`service.compute.processes.PRELOAD`), after the service's
modules: it builds the IWR's runtimes there, once, for every helper forked from it
(`service.compute.registry.preload`).

The build runs only when the forkserver itself is the importer: a process that imports every module (a test of
the package's members, a documentation tool) pays nothing and keeps no registry it did not ask for.
"""

from __future__ import annotations

import sys
from multiprocessing import forkserver
from types import FrameType

from service.compute.registry import preload


def _imported_by_the_forkserver() -> bool:
    """Whether multiprocessing's forkserver loop (`forkserver.main`, which imports its preload list before its
    first fork) is on the stack of this import."""
    frame: FrameType | None = sys._getframe()
    while frame is not None:
        if frame.f_code is forkserver.main.__code__:
            return True
        frame = frame.f_back
    return False


if _imported_by_the_forkserver():
    preload()
