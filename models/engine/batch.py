"""The batch engine: compiled Functions evaluated over N poses straight from numpy memory.

Per-pose inputs are arrays (N, k) or (N, r, c); shared inputs (params) are
1-D and broadcast. A Function mapped over n poses wraps the compiled one (no
re-derivation, no compiling), so a new n costs microseconds; the most recent
maps are kept per `BatchFunctions` (owned by its `models.engine.runtime.Runtime`).
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from dataclasses import dataclass, field

import casadi as ca
import numpy as np
from numpy.typing import NDArray

MAP_CACHE_SIZE = 64
PARALLEL_FROM = 256
"""Batches of at least this many poses are evaluated on two threads."""
EXACT_UP_TO = 64
"""Batches up to this size get a map of their own size; larger ones are padded to the next of eight sizes per
doubling (at most 1/8 more rows). An iterative solver's batch shrinks as its targets converge: a map per
size was a new Function at almost every Newton iteration (14-140 ms each at 10 000 targets, 0.7 s of a
10 000-target compensation), the padded sizes repeat."""


def padded_size(n: int) -> int:
    """The map size a batch of `n` poses is evaluated with (>= n)."""
    if n <= EXACT_UP_TO:
        return n
    step = 1 << (n.bit_length() - 4)  # an eighth of the power of two at or below n
    return -(-n // step) * step


@dataclass
class BatchFunctions:
    """Compiled Functions of one structure, by name, with their differentiable originals."""

    functions: dict[str, ca.Function]
    """Differentiable CasADi Functions (SX, or MX around the rootfinder)."""
    native: dict[str, ca.Function]
    """Compiled versions of the batch Functions (or the same SX ones when no compiler is available)."""
    _maps: OrderedDict[tuple[str, int], ca.Function] = field(default_factory=OrderedDict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __getitem__(self, name: str) -> ca.Function:
        return self.functions[name]

    def batch(
        self, name: str, *args: NDArray[np.float64], conditions: NDArray[np.float64] | None = None
    ) -> tuple[NDArray[np.float64], ...]:
        """Evaluate native `name` over N poses, reading and writing numpy memory directly.

        Outputs are (N, k) for vectors, (N, r, c) for matrices. Going through CasADi's buffer interface skips
        DM conversion, which otherwise costs ten times the evaluation itself. `conditions` (N, 7) feeds the
        last input of a structure with model terms (`models.description.terms`); not given, the reference conditions
        (no temperature difference, no payload): what a caller that knows no terms means. Functions without
        the input ignore it.
        """
        base = self.native[name]
        if base.n_in() == len(args) + 1 and base.name_in(len(args)) == "conditions":
            args = (*args, np.zeros(base.size1_in(len(args))) if conditions is None else conditions)
        n = max((a.shape[0] for a in args if a.ndim >= 2), default=1)
        size = padded_size(n)
        mapped = self.mapped(name, size)
        buffer, trigger = mapped.buffer()
        keep: list[NDArray[np.float64]] = []
        for i, arg in enumerate(args):
            rows, cols = base.size_in(i)
            if arg.ndim == 1:
                flat = np.empty((size, rows * cols))
                flat[:] = np.asarray(arg, dtype=float).reshape(rows * cols)
            else:
                if arg.ndim == 3:
                    arg = arg.transpose(0, 2, 1)  # noqa: PLW2901  (CasADi stores matrices column by column)
                flat = np.empty((size, rows * cols))
                flat[:n] = np.asarray(arg, dtype=float).reshape(n, rows * cols)
                flat[n:] = flat[n - 1] if n else 0.0  # padding rows: a copy of a real one (finite, harmless)
            keep.append(flat)
            buffer.set_arg(i, flat.data)
        outputs = []
        for i in range(base.n_out()):
            rows, cols = base.size_out(i)
            out = np.empty((size, cols, rows))
            buffer.set_res(i, out.data)
            outputs.append(out[:n])
        trigger()
        return tuple(o[:, 0, :] if o.shape[1] == 1 else o.transpose(0, 2, 1) for o in outputs)

    def mapped(self, name: str, n: int) -> ca.Function:
        """The native `name` over n poses at once: per-pose inputs become columns, `params` is shared."""
        key = (name, n)
        with self._lock:
            found = self._maps.get(key)
            if found is not None:
                self._maps.move_to_end(key)
                return found
        # Inputs given as a single column (params) are broadcast to all n by CasADi. Small batches run
        # serially: starting threads costs more than they save below a few hundred poses.
        mapped = self.native[name].map(n, "thread", 2) if n >= PARALLEL_FROM else self.native[name].map(n, "serial")
        with self._lock:
            self._maps[key] = mapped
            while len(self._maps) > MAP_CACHE_SIZE:
                self._maps.popitem(last=False)
        return mapped
