"""Compile CasADi Functions to a native library once, and keep it on disk.

CasADi's virtual machine costs ~6 ns per SX instruction; the same graph
compiled by the system C compiler runs 5-10x faster, which is what makes
batched kinematics of 10 000 poses fit in a fraction of a second. The
Functions' serialised graphs are hashed, and C source is generated and
compiled only when no library with that hash exists in the cache directory,
so a warm start loads without generating any code and a changed model can
never load a stale library.

A library already in the cache is loaded whether or not a compiler is on
PATH: a runtime image built in two stages ships the library the build stage
compiled, and no compiler. Nothing to load and no compiler (or
`IWR_NATIVE=0`, or a failed compilation): the original Functions are returned
and everything still works on CasADi's virtual machine, 5-10x slower. That is
what a structure first seen in the runtime container gets (decided: the image
stays without a toolchain; its build stage compiles the structures it warms):
a warning in the log, once per library, and the library's name and reason in
`vm_only_libraries()`, which the service exports as the Prometheus counter
`iwr_vm_only_structures_total{reason}`.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import os
import shutil
import subprocess
import tempfile
import threading
from collections.abc import Iterator
from enum import StrEnum
from pathlib import Path

import casadi as ca

log = logging.getLogger(__name__)

COMPILE_FLAGS = ("-fPIC", "-shared")
COMPILE_TIMEOUT_S = 300
OPTIMIZATION_LEVELS = ("0", "1", "2")
"""`IWR_NATIVE_OPT_LEVEL`: gcc's -O of the libraries; 1 by default. The register allocator is most of a build
(CasADi writes each Function as one long basic block): -O1 builds a group of the IWR's Functions in 1.5 s of gcc
and evaluates a batch of pose Jacobians at 8 us a pose; -O0 builds it in 0.55 s and evaluates at 15-19 us, the
same numbers to the bit (x86-64's baseline has no fused multiply-add to contract to). -O0 is for processes that
build many structures and evaluate each a little: the test suite, on a cold cache (docs/development.md)."""


class VmReason(StrEnum):
    """Why a library's Functions run on CasADi's virtual machine."""

    NO_COMPILER = "no_compiler"
    COMPILE_FAILED = "compile_failed"
    DISABLED = "disabled"


_vm_only: dict[str, VmReason] = {}
_vm_lock = threading.Lock()


def vm_only_libraries() -> dict[str, VmReason]:
    """The libraries (by name: `robot_<structure tag>`, `ik_<tag>`, …) this process evaluates on CasADi's VM,
    and why; a process-wide record (a structure is built once per process), read by the service's metrics."""
    with _vm_lock:
        return dict(_vm_only)


def vm_only_structures() -> dict[str, VmReason]:
    """The structures (by tag) with at least one library on CasADi's VM, and why (a library is named
    `<kind>_<structure tag>`)."""
    return {name.split("_", 1)[-1]: reason for name, reason in vm_only_libraries().items()}


def _on_vm(name: str, reason: VmReason, functions: list[ca.Function]) -> dict[str, ca.Function]:
    with _vm_lock:
        _vm_only[name] = reason
    return {f.name(): f for f in functions}


def cache_dir() -> Path:
    configured = os.environ.get("IWR_CACHE_DIR")
    if configured:
        return Path(configured)
    return Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "iwr-calibration"


def native_enabled() -> bool:
    """Whether native libraries are used at all (`IWR_NATIVE=0` turns them off)."""
    return os.environ.get("IWR_NATIVE", "1") != "0"


def optimization_flag() -> str:
    """gcc's -O for the libraries built now: `IWR_NATIVE_OPT_LEVEL` (0, 1 or 2), 1 when unset."""
    level = os.environ.get("IWR_NATIVE_OPT_LEVEL", "1")
    if level not in OPTIMIZATION_LEVELS:
        raise ValueError(f"IWR_NATIVE_OPT_LEVEL={level!r}: use one of {', '.join(OPTIMIZATION_LEVELS)}")
    return f"-O{level}"


def compile_flags() -> tuple[str, ...]:
    """The compiler's flags, part of every library's hash: a library built at another level is another file."""
    return (optimization_flag(), *COMPILE_FLAGS)


def compiler_available() -> bool:
    return shutil.which(_compiler()) is not None


def _compiler() -> str:
    return os.environ.get("CC", "cc")


PARTS = 2
"""A library of several Functions is compiled as this many libraries at once, its Functions dealt to them by
size: the compiler is the build (a 7R arm's two libraries: 4.4 s and 3.1 s of gcc for 0.5 and 0.36 MB of C, and
the rest of its build well under a second), and one compiler is one core. Fixed, not the machine's core count:
the split is part of every library's hash, and a runtime image must find what its build stage compiled on
another machine."""


def library_path(name: str, serialised: list[str]) -> Path:
    """Where the library of Functions with these serialised graphs lives: named by the hash of the graphs,
    CasADi's version (which writes the C) and the compiler flags.

    The serialised graph, not the generated C source, is hashed: it names the same computation, and
    `Function.serialize` takes a third of the time of generating the source (0.4 s against 1.2 s for the IWR's
    five libraries), which every process paid at start-up only to find the library it already had.
    """
    digest = hashlib.sha256()
    for part in (ca.__version__, " ".join(compile_flags()), *serialised):
        digest.update(part.encode())
        digest.update(b"\0")
    return cache_dir() / f"{name}-{digest.hexdigest()[:16]}.so"


def _parts(name: str, functions: list[ca.Function]) -> list[tuple[Path, list[ca.Function]]]:
    """`functions` dealt into at most `PARTS` libraries of about equal size (largest first, each to the lightest
    part; ties by name, so every process deals alike), each with its path. One library keeps the plain name."""
    serialised = {f.name(): f.serialize() for f in functions}
    count = min(PARTS, len(functions))
    parts: list[list[ca.Function]] = [[] for _ in range(count)]
    loads = [0] * count
    for f in sorted(functions, key=lambda f: (-len(serialised[f.name()]), f.name())):
        lightest = loads.index(min(loads))
        parts[lightest].append(f)
        loads[lightest] += len(serialised[f.name()])
    names = [name] if count == 1 else [f"{name}.{i}" for i in range(count)]
    return [
        (library_path(part_name, [serialised[f.name()] for f in part]), part)
        for part_name, part in zip(names, parts, strict=True)
    ]


def _c_source(functions: list[ca.Function]) -> str:
    # The generator's name only names its file (the library's exported symbols are the Functions' names).
    gen = ca.CodeGenerator("functions.c", {"with_header": False, "casadi_real": "double"})
    for f in functions:
        gen.add(f)
    return str(gen.dump())


def compile_functions(name: str, functions: list[ca.Function]) -> dict[str, ca.Function]:
    """Native versions of `functions` (same names and signatures), or the originals if there are none.

    Hashing the Functions needs no compiler, so existing libraries are found by their hashes and loaded even
    where none is installed; the C source is generated only to build. The libraries missing are compiled at once.
    """
    if not native_enabled():
        return _on_vm(name, VmReason.DISABLED, functions)
    parts = _parts(name, functions)
    if any(not library.exists() for library, _ in parts):
        if not compiler_available():
            log.warning(
                "no C compiler (%s) and no built library %s in %s: %s runs on CasADi's virtual machine (5-10x "
                "slower); a structure new to this container does (see the README, 'The container')",
                _compiler(),
                ", ".join(library.name for library, _ in parts if not library.exists()),
                cache_dir(),
                name,
            )
            return _on_vm(name, VmReason.NO_COMPILER, functions)
        try:
            with _build_locks([library for library, _ in parts]):
                # Another process (a test worker, a second job worker on a cold cache) may have built them while
                # this one waited: a minute of compiler for the largest structures, not to be spent twice.
                missing = [(library, part) for library, part in parts if not library.exists()]
                _build([(_c_source(part), library) for library, part in missing])
        except (OSError, subprocess.CalledProcessError, subprocess.TimeoutExpired) as exc:
            log.warning("native compilation of %s failed (%s); using the CasADi VM", name, exc)
            return _on_vm(name, VmReason.COMPILE_FAILED, functions)
    native = {f.name(): ca.external(f.name(), str(library)) for library, part in parts for f in part}
    with _vm_lock:  # built natively now: no longer on the VM, whatever an earlier build in this process recorded
        _vm_only.pop(name, None)
    return native


@contextlib.contextmanager
def _build_locks(libraries: list[Path]) -> Iterator[None]:
    """Held while `libraries` are built: one builder per library across the processes and threads that share the
    cache directory (flock is per open file, so threads of one process exclude each other too). Taken in the
    order of their names, so two builders of overlapping sets cannot wait on each other."""
    with contextlib.ExitStack() as stack:
        for library in sorted(libraries):
            library.parent.mkdir(parents=True, exist_ok=True)
            handle = stack.enter_context(open(library.parent / f"{library.name}.lock", "w"))
            fcntl.flock(handle, fcntl.LOCK_EX)
            stack.callback(fcntl.flock, handle, fcntl.LOCK_UN)
        yield


def _build(sources: list[tuple[str, Path]]) -> None:
    """Compile each (C source, library) with its own compiler process, all at once; each library appears
    whole (an atomic rename) once its compiler has succeeded."""
    if not sources:
        return
    with tempfile.TemporaryDirectory(dir=sources[0][1].parent) as tmp:
        running: list[tuple[list[str], subprocess.Popen[bytes], Path, Path]] = []
        try:
            for i, (source, library) in enumerate(sources):
                c_file = Path(tmp) / f"functions{i}.c"
                c_file.write_text(source)
                tmp_lib = Path(tmp) / library.name
                command = [_compiler(), *compile_flags(), str(c_file), "-o", str(tmp_lib), "-lm"]
                process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
                running.append((command, process, tmp_lib, library))
            for command, process, _, _ in running:
                output, _ = process.communicate(timeout=COMPILE_TIMEOUT_S)
                if process.returncode != 0:
                    raise subprocess.CalledProcessError(process.returncode, command, output)
        finally:
            for _, process, _, _ in running:
                if process.poll() is None:
                    process.kill()
                    process.wait()
                if process.stdout is not None:
                    process.stdout.close()
        for _, _, tmp_lib, library in running:
            # Atomic rename: concurrent processes never load a half-written library.
            os.replace(tmp_lib, library)
