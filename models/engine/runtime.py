"""Everything built from a robot structure, owned by a `Runtime`; runtimes owned by a `Registry`.

The CasADi graphs depend only on `RobotDescription.structure` (its stages' tokens: per link its convention,
joint type and Hayati parameter, and where the hexapod sits): geometry, base, tool and data are inputs. A `Runtime`
builds each artefact of one structure once, on first use, and keeps it:

- `kinematics`: the kinematic Functions (`models.engine.symbolic`), compiled (`models.engine.native`) behind the batch
  engine (`models.engine.batch`);
- the inverse kinematics' KKT Functions and IPOPT NLPs, and its start tables (`models.inverse`);
- the identification's pool of IPOPT solvers (`models.identification.solver`);
- the structural identifiable subsets and the workspace samples (`models.identifiability`, `models.workspace`).

Modules ask for an artefact by name and key (`Runtime.artefact`), so the runtime knows nothing of the layers
above it; it counts builds per artefact (tests assert that each happens once) and times them.

A `Registry` holds the runtimes of the most recently used structures (bounded, thread-safe). Library calls
that are given no runtime use `default_registry()`, the one process-wide registry, documented here; an
application creates its own `Registry` and passes `runtime=registry.runtime(desc)` to every call.
"""

from __future__ import annotations

import hashlib
import logging
import threading
import time
from collections import Counter, OrderedDict
from collections.abc import Callable, Hashable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar, cast

from models.description.robot import RobotDescription, Structure
from models.description.serial_chain import JointType
from models.engine import cancellation
from models.engine.batch import BatchFunctions
from models.engine.native import compile_functions
from models.engine.symbolic import NATIVE_FUNCTIONS, densified, kinematic_functions

if TYPE_CHECKING:
    from collections.abc import Iterator

log = logging.getLogger(__name__)

T = TypeVar("T")

DEFAULT_CAPACITY = 8
"""Structures a registry keeps; an application serves a handful (one per robot family)."""

Warmer = Callable[[RobotDescription, "Runtime"], None]
"""Builds one layer's artefacts of a runtime ahead of the first request (identification, inverse kinematics)."""


_JOINT_LETTER = {JointType.PRISMATIC.value: "p", JointType.REVOLUTE.value: "r", JointType.FIXED.value: "f"}
_TAG_LIMIT = 48


def structure_tag(structure: Structure) -> str:
    """A file-name-safe tag of a structure, naming its compiled libraries (which are cached by content).

    The IWR's shape (standard-DH joints, then the hexapod) keeps its tag of joint letters ("pprr"); any
    other structure reads per link `d`/`m` (convention), `p`/`r`/`f` (joint), `b` (Hayati's beta), and `h`
    where the hexapod stage sits, e.g. a 7R MDH arm "mrbmrmrmrmrmrmr". Built from enumerations only: no
    user string reaches a file name or generated code. A structure with model terms adds `_t` (thermal) and
    `_c` (compliance) to its geometric tag.
    """
    if structure and structure[0] == "terms":
        _, thermal, compliance, geometric = structure
        assert isinstance(geometric, tuple)
        return structure_tag(geometric) + ("_t" if thermal else "") + ("_c" if compliance else "")
    if all(isinstance(j, JointType) for j in structure):
        return "".join("p" if j is JointType.PRISMATIC else "r" for j in structure)
    if structure[0] == "stages":  # any chain of stages: each serial stage's links, each other stage's initial
        _, stages = structure
        assert isinstance(stages, tuple)
        tag = "_".join(_links_tag(token) if kind == "serial" else str(kind)[0] for kind, token in stages)
    else:
        tokens, hexapod_at = structure
        assert isinstance(tokens, tuple)
        parts = [_links_tag((token,)) for token in tokens]
        if hexapod_at is not None:
            assert isinstance(hexapod_at, int)
            parts.insert(hexapod_at, "h")
        tag = "".join(parts)
    if len(tag) > _TAG_LIMIT:
        tag = tag[:_TAG_LIMIT] + hashlib.sha256(tag.encode()).hexdigest()[:12]
    return tag


def _links_tag(tokens: object) -> str:
    assert isinstance(tokens, tuple)
    return "".join(
        ("d" if conv == "dh" else "m") + _JOINT_LETTER[joint] + ("b" if beta else "") for conv, joint, beta in tokens
    )


class Runtime:
    """The artefacts of one robot structure, each built once (see the module docstring)."""

    def __init__(self, desc: RobotDescription) -> None:
        self.structure: Structure = desc.structure
        self.tag = structure_tag(self.structure)
        self._desc = desc
        """A description of this structure, for builders that depend on the structure alone."""
        self._lock = threading.Lock()
        self._stores: dict[str, OrderedDict[Hashable, Any]] = {}
        self._gates: dict[tuple[str, Hashable], threading.Lock] = {}
        self._builds: Counter[str] = Counter()
        self._seconds: dict[str, float] = {}
        self._kinematics: BatchFunctions | None = None

    def __repr__(self) -> str:
        return f"Runtime({self.tag!r}, builds={dict(self._builds)})"

    # ------------------------------------------------------------------ bookkeeping
    @property
    def builds(self) -> dict[str, int]:
        """Builds so far per artefact name (a snapshot)."""
        with self._lock:
            return dict(self._builds)

    @property
    def build_seconds(self) -> dict[str, float]:
        """Time spent building, per artefact name (a snapshot)."""
        with self._lock:
            return dict(self._seconds)

    def count(self, name: str, seconds: float = 0.0) -> None:
        """Record a build made by an artefact itself (e.g. a solver pool growing)."""
        with self._lock:
            self._builds[name] += 1
            self._seconds[name] = self._seconds.get(name, 0.0) + seconds

    def check(self, desc: RobotDescription) -> None:
        if desc.structure != self.structure:
            raise ValueError(
                f"this runtime serves the structure {self.tag!r}, not {structure_tag(desc.structure)!r} "
                "(ask the registry for the description's runtime)"
            )

    # ------------------------------------------------------------------ artefacts
    def artefact(self, name: str, key: Hashable, build: Callable[[], T], *, capacity: int | None = None) -> T:
        """The artefact `name` for `key`, built by `build()` the first time (once, even under concurrency).

        `capacity` bounds how many keys of this artefact are kept (least recently used go first): for artefacts
        keyed by data, such as the start tables of calibrated parameter vectors.
        """
        with self._lock:
            store = self._stores.setdefault(name, OrderedDict())
            if key in store:
                store.move_to_end(key)
                return cast(T, store[key])
            gate = self._gates.setdefault((name, key), threading.Lock())
        # One builder per (name, key); other threads wait for it instead of building the same thing again,
        # while lookups of other artefacts go on.
        with gate:
            with self._lock:
                if key in store:
                    store.move_to_end(key)
                    return cast(T, store[key])
            started = time.perf_counter()
            if capacity is None:  # a structure's own artefact, built once: its first use (models.engine.cancellation)
                with cancellation.structure_build():
                    value = build()
            else:  # keyed by data (a calibrated parameter vector's tables): a request's own work
                value = build()
            seconds = time.perf_counter() - started
            with self._lock:
                store[key] = value
                self._builds[name] += 1
                self._seconds[name] = self._seconds.get(name, 0.0) + seconds
                self._gates.pop((name, key), None)
                while capacity is not None and len(store) > capacity:
                    store.popitem(last=False)
        return value

    @property
    def kinematics(self) -> BatchFunctions:
        """The kinematic Functions of this structure and their compiled batch versions."""
        found = self._kinematics
        if found is None:
            found = self._kinematics = self.artefact("kinematics", None, self._build_kinematics)
        return found

    def _build_kinematics(self) -> BatchFunctions:
        started = time.perf_counter()
        fn = kinematic_functions(self._desc)
        # Dense outputs: the batch interface reads results as plain arrays.
        dense = [densified(fn[name]) for name in NATIVE_FUNCTIONS if name in fn]
        built = BatchFunctions(functions=fn, native=compile_functions("robot_" + self.tag, dense))
        # The one build a new structure costs (measured for a 7R arm: 7.8 s with a cold library cache,
        # 0.15 s loading the cached library).
        log.info("structure %s: kinematics built in %.2f s", self.tag, time.perf_counter() - started)
        return built

    def warm(self, desc: RobotDescription, warmers: Sequence[Warmer] = ()) -> float:
        """Build the kinematics and whatever `warmers` build (the layers above pass theirs: see `models.warm`,
        so the core never imports them); the seconds it took (≈0 when already warm)."""
        self.check(desc)
        started = time.perf_counter()
        _ = self.kinematics
        for warmer in warmers:
            warmer(desc, self)
        return time.perf_counter() - started


class Registry:
    """The runtimes of the most recently used structures: bounded, thread-safe, injectable."""

    def __init__(self, capacity: int = DEFAULT_CAPACITY) -> None:
        if capacity < 1:
            raise ValueError("a registry keeps at least one structure")
        self.capacity = capacity
        self._runtimes: OrderedDict[Structure, Runtime] = OrderedDict()
        self._lock = threading.Lock()
        self.created = 0
        """Runtimes created so far (evicted structures that come back count again)."""

    def __len__(self) -> int:
        with self._lock:
            return len(self._runtimes)

    def __iter__(self) -> Iterator[Runtime]:
        with self._lock:
            return iter(list(self._runtimes.values()))

    def __contains__(self, desc: object) -> bool:
        with self._lock:
            return isinstance(desc, RobotDescription) and desc.structure in self._runtimes

    def runtime(self, desc: RobotDescription) -> Runtime:
        """The runtime of `desc`'s structure, created (empty: artefacts build on first use) if new."""
        key = desc.structure
        with self._lock:
            found = self._runtimes.get(key)
            if found is not None:
                self._runtimes.move_to_end(key)
                return found
            found = self._runtimes[key] = Runtime(desc)
            self.created += 1
            while len(self._runtimes) > self.capacity:
                self._runtimes.popitem(last=False)
            return found

    def warm(self, desc: RobotDescription, warmers: Sequence[Warmer] = ()) -> float:
        """Build what `desc` needs now (at start-up), and return the build time in seconds."""
        runtime = self.runtime(desc)
        seconds = runtime.warm(desc, warmers)
        log.info("runtime %s warm in %.2f s (builds: %s)", runtime.tag, seconds, runtime.builds)
        return seconds

    def clear(self) -> None:
        with self._lock:
            self._runtimes.clear()


_DEFAULT_REGISTRY = Registry()
"""The process-wide registry behind `default_registry()`; the only one a library call creates by itself."""


def default_registry() -> Registry:
    """The process-wide registry used when a call is given no runtime (library convenience)."""
    return _DEFAULT_REGISTRY


def runtime_for(desc: RobotDescription, runtime: Runtime | None = None) -> Runtime:
    """`runtime` checked against `desc`, or the default registry's runtime of `desc`'s structure."""
    if runtime is None:
        return _DEFAULT_REGISTRY.runtime(desc)
    runtime.check(desc)
    return runtime
