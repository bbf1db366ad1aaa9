"""Foundation: batched FK + identification Jacobian, and the cost of building the Functions."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from benchmarks.timing import best_of, target
from models import Registry, forward_kinematics, iwr, sample_workspace
from models.engine import native

N = 10_000

_COLD = """
import sys, time
t = time.perf_counter()
from models import Registry, iwr, native
from models.description.examples import iiwa_like
from models.warm import warm_everything
t_import = time.perf_counter()
native.PARTS = int(sys.argv[2])
warm_everything(Registry(), iwr() if sys.argv[1] == "iwr" else iiwa_like())
print(t_import - t, time.perf_counter() - t_import)
"""
"""Everything a new robot's first request may need (what `POST /v1/robots` builds in the background): the
kinematics, the inverse kinematics and the identification's solvers, in a fresh process."""


def _start(cache_dir: str, robot: str = "iwr", parts: int | None = None) -> tuple[float, float]:
    env = {**os.environ, "IWR_CACHE_DIR": cache_dir}
    command = [sys.executable, "-c", _COLD, robot, str(parts or native.PARTS)]
    out = subprocess.run(command, env=env, capture_output=True, text=True, check=True)
    imp, build = (float(v) for v in out.stdout.split())
    return imp, build


def _cold(robot: str, parts: int | None = None) -> float:
    """The build of `robot`'s structure from an empty cache: derive, generate C, compile, load."""
    with tempfile.TemporaryDirectory() as cache:
        return _start(cache, robot, parts)[1]


def run() -> dict[str, object]:
    with tempfile.TemporaryDirectory() as cache:
        import_s, cold_build = _start(cache)  # empty cache: derive + generate C + compile
        _, warm_build = _start(cache)  # library on disk: derive + hash + load
    # The baseline in the same run: each library compiled whole, by one compiler (PARTS = 1).
    cold_build_one_compiler = _cold("iwr", parts=1)
    cold_7r = _cold("7r")
    cold_7r_one_compiler = _cold("7r", parts=1)
    desc = iwr()
    runtime = Registry().runtime(desc)  # the benchmark's own, like an application's
    fns = runtime.kinematics
    joints = sample_workspace(desc, N, seed=1, runtime=runtime)
    forward_kinematics(desc, joints, jacobian=True, runtime=runtime)  # first map of this size
    batch = best_of(lambda: forward_kinematics(desc, joints, jacobian=True, runtime=runtime), 5)

    theta = desc.parameters.nominal
    assert desc.hexapod is not None
    home = np.array(desc.hexapod.home)

    def loop_same_functions() -> None:
        for q in joints:
            x, _ = fns.native["newton_solve"](q, theta, home)
            fns.native["pose_jacobian_at"](q, theta, x)

    started = time.perf_counter()
    loop_same_functions()
    loop = time.perf_counter() - started
    started = time.perf_counter()
    for q in joints[:1000]:
        forward_kinematics(desc, q, jacobian=True, runtime=runtime)
    loop_api = (time.perf_counter() - started) * N / 1000
    return {
        "poses": N,
        "batch_fk_jacobian_s": batch,
        "loop_same_functions_s": loop,
        "loop_public_api_s_extrapolated": loop_api,
        "speedup_vs_loop": loop / batch,
        "import_s": import_s,
        "cold_build_s": cold_build,
        "cold_build_one_compiler_s": cold_build_one_compiler,
        "cold_build_7r_s": cold_7r,
        "cold_build_7r_one_compiler_s": cold_7r_one_compiler,
        "warm_start_build_s": warm_build,
        "targets": [
            target("batched FK + Jacobian, 10 000 poses (s)", batch, 1.0),
            target("speed-up vs pose-by-pose loop of the same Functions", loop / batch, 10.0, ">="),
            target("IWR: cold build of everything a first request needs, empty cache (s)", cold_build, 5.0),
            target("7R arm: cold build of everything a first request needs, empty cache (s)", cold_7r, 3.0),
        ],
    }
