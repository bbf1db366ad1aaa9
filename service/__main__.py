"""`python -m service [--host H] [--port P]`: serve the API with uvicorn (settings from the environment);
`python -m service --warm-only`: build the native libraries into the cache and exit."""

from __future__ import annotations

import argparse
import os

# Before numpy loads: requests run concurrently, each on small matrices, where BLAS threads only contend
# (one FK request took 4 ms with two OpenBLAS threads, 0.6 ms with one).
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
# Synchronous computations in processes of their own, one per core (service.compute.pool): in threads they compete
# with the event loop for the GIL (/healthz p99 1.08 s under the mixed load, 50 ms wanted).
os.environ.setdefault("IWR_COMPUTE_PROCESSES", str(os.cpu_count() or 1))

import signal  # noqa: E402
import sys  # noqa: E402
from types import FrameType  # noqa: E402

import uvicorn  # noqa: E402

from models.engine.native import optimization_flag  # noqa: E402
from service.compute.limits import DEADLINE_PER_BUDGET, GIL_SWITCH_INTERVAL_S  # noqa: E402
from service.compute.registry import build_registry  # noqa: E402
from service.http import slow_clients  # noqa: E402
from service.http.app import create_app  # noqa: E402
from service.settings import get_settings  # noqa: E402


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m service", description=__doc__)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=8000)
    parser.add_argument(
        "--warm-only",
        action="store_true",
        help="build every native library the service builds at start-up into the cache directory "
        "(IWR_CACHE_DIR), then exit: the image's build stage, which has the compiler the runtime stage lacks",
    )
    args = parser.parse_args(argv)
    try:
        optimization_flag()  # IWR_NATIVE_OPT_LEVEL refused before anything is built with it, not at a first request
    except ValueError as exc:
        parser.error(str(exc))
    if args.warm_only:
        build_registry(get_settings().model_copy(update={"warm_up": True}))
        return
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)
    # The served API stops what runs past its deadline (503); an app made by create_app alone (tests, scripts,
    # whose machine may be busy with anything) has none unless configured.
    settings = get_settings()
    if "IWR_COMPUTE_DEADLINE_SECONDS" not in os.environ:  # 2.5 budgets, whatever the budget is set to
        deadline = DEADLINE_PER_BUDGET * settings.sync_budget_seconds
        settings = settings.model_copy(update={"compute_deadline_seconds": deadline})
    signal.signal(signal.SIGTERM, _exit_cleanly)
    uvicorn.run(
        create_app(settings),
        host=args.host,
        port=args.port,
        log_level="warning",
        access_log=False,
        http=slow_clients.protocol(settings.header_timeout_seconds),  # slowloris: uvicorn has no header deadline
    )


def _exit_cleanly(_signum: int, _frame: FrameType | None) -> None:
    """SIGTERM (systemd, docker stop, Kubernetes) once uvicorn has shut down: a normal exit, status 0.

    Uvicorn handles SIGTERM itself, shuts down gracefully, then restores the handler it found and raises the
    signal again. With the default handler that kills the process at once, before multiprocessing's finalisers
    release the compute pools' semaphores: "resource_tracker: There appear to be 10 leaked semaphore objects"
    at every stop. SystemExit unwinds the interpreter normally instead.
    """
    raise SystemExit(0)


if __name__ == "__main__":
    main()
