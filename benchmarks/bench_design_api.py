"""Pose designs as a client sees them: through the HTTP API of a live server (`python -m service`, compute
processes as `make run` starts them), against the library's own call in this process, in the same run.

K = 30 of M = 2 000 sampled candidates, full pose, the IWR, one design at a time, warm (a first design of each
criterion is made before timing). For each criterion: the wall time of the synchronous request, the service's
own `seconds` and its split (candidate information, relaxation and its certificate, greedy and exchange,
rounding), and the same design by the library here. A design the service refuses synchronously (its estimate
over the synchronous budget) is timed as a job (`?async=true`, submitted to succeeded). The remainder between
the request's wall and the service's `seconds` is HTTP, the hop to the compute process, storing the design and
the response.

D at M = 20 000 goes through a second server whose synchronous budget (`IWR_SYNC_BUDGET_SECONDS`, a setting) admits
it (LARGE_BUDGET_S): under the default 2 s budget the service's estimate sends it to a job, as it should; the
issue's target for it is a 5 s wall.
Walls are medians of REPEAT designs (seeds 1-3); the targets are on the medians.
"""

from __future__ import annotations

import statistics
import tempfile
import time
from typing import Any

import httpx

from benchmarks.timing import markdown_table, target
from harness.live import running_server
from models import Registry, iwr
from optimal_design import design_poses

CRITERIA = ("D", "A", "I", "E", "condition")
TARGETS_S = {"D": 0.5, "A": 1.0, "I": 1.0, "E": 2.0, "condition": 2.0}
"""Issue 30's targets for K = 30 of M = 2 000, synchronous."""
REPEAT = 3
LARGE_BUDGET_S = 6.0
"""The synchronous budget of the server that takes D at M = 20 000: above the service's estimate for it
(service.compute.limits.pose_design: 3.2 s since its recalibration on the dspeed branch, 5.85 s before), with room for
the
shared machine's load (the compute deadline is 2.5 budgets)."""


def _body(criterion: str, m: int, seed: int) -> dict[str, object]:
    return {"count": 30, "criterion": criterion, "candidate_count": m, "seed": seed}


def _through_api(http: httpx.Client, robot: str, criterion: str, m: int) -> dict[str, Any]:
    walls, reports = [], []
    mode = "synchronous"
    for seed in range(1, REPEAT + 1):
        body = _body(criterion, m, seed)
        started = time.perf_counter()
        answer = http.post(f"/v1/robots/{robot}/pose-designs", json=body)
        if answer.status_code == 422 and "async=true" in answer.text:
            mode = "job (refused synchronously: estimated over the budget)"
            accepted = http.post(f"/v1/robots/{robot}/pose-designs", params={"async": "true"}, json=body)
            accepted.raise_for_status()
            job_url = f"/v1/jobs/{accepted.json()['job_id']}"
            while (job := http.get(job_url).json())["status"] in ("queued", "running"):
                time.sleep(0.02)
            assert job["status"] == "succeeded", job
            walls.append(time.perf_counter() - started)
            reports.append(job["result"])
            continue
        answer.raise_for_status()
        walls.append(time.perf_counter() - started)
        reports.append(answer.json())
    best = min(range(REPEAT), key=lambda k: walls[k])
    report = reports[best]
    relaxation = report["relaxation"] or {}
    return {
        "mode": mode,
        "wall_s": walls[best],
        "wall_median_s": statistics.median(walls),
        "efficiencies": [r["efficiency"] for r in reports],
        "bounds": [(r["bound"] or {}).get("value") for r in reports],
        "service_seconds": report["seconds"],
        "information_s": relaxation.get("information_s"),
        "relaxation_s": relaxation.get("relaxation_s"),
        "greedy_exchange_s": relaxation.get("greedy_exchange_s"),
        "rounding_exchange_s": relaxation.get("rounding_exchange_s"),
        "outside_the_design_s": walls[best] - report["seconds"],
        "efficiency": report["efficiency"],
    }


def _in_library(criterion: str, m: int) -> float:
    desc, registry = iwr(), Registry()
    runtime = registry.runtime(desc)
    design_poses(desc, 30, criterion, candidate_count=200, seed=9, runtime=runtime)  # warm
    walls = []
    for seed in range(1, REPEAT + 1):
        started = time.perf_counter()
        design_poses(desc, 30, criterion, candidate_count=m, seed=seed, runtime=runtime)
        walls.append(time.perf_counter() - started)
    return min(walls)


def _table(rows: dict[str, dict[str, Any]]) -> list[str]:
    header = ["design (K = 30)", "how", "API wall, median (best) (s)", "service `seconds`",
              "information / relaxation / greedy / rounding (s)", "outside the design (s)", "library here (s)",
              "efficiency (seeds 1-3)"]  # fmt: skip
    lines = []
    for name, r in rows.items():
        split = " / ".join(
            f"{float(r[k]):.2f}" if r[k] is not None else "—"
            for k in ("information_s", "relaxation_s", "greedy_exchange_s", "rounding_exchange_s")
        )
        efficiencies = " / ".join(f"{e:.3f}" for e in r["efficiencies"])
        lines.append(
            [
                name,
                r["mode"],
                f"{r['wall_median_s']:.2f} ({r['wall_s']:.2f})",
                f"{r['service_seconds']:.2f}",
                split,
                f"{r['outside_the_design_s']:.2f}",
                f"{r['library_s']:.2f}",
                efficiencies,
            ]
        )
    return markdown_table(header, lines)


def _sync_target(name: str, row: dict[str, Any], limit: float) -> dict[str, object]:
    """The target is a synchronous answer: a design refused synchronously misses it whatever its job took."""
    if row["mode"] == "synchronous":
        return target(f"{name} through the API, synchronous, median (s)", row["wall_median_s"], limit)
    missed = target(f"{name} through the API: refused synchronously, as a job, median (s)", row["wall_median_s"], limit)
    missed["met"] = False
    return missed


def run() -> dict[str, object]:
    rows: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        with running_server(f"sqlite:///{tmp}/design.db") as url, httpx.Client(base_url=url, timeout=600) as http:
            robot = http.post("/v1/robots", json={"name": "design-bench"}).json()["id"]
            for criterion in CRITERIA:  # one design of each first: every compute process warm for it
                http.post(f"/v1/robots/{robot}/pose-designs", json=_body(criterion, 200, 9))
            for criterion in CRITERIA:
                rows[f"{criterion}, M = 2000"] = _through_api(http, robot, criterion, 2000)
        with (
            running_server(f"sqlite:///{tmp}/large.db", IWR_SYNC_BUDGET_SECONDS=str(LARGE_BUDGET_S)) as url,
            httpx.Client(base_url=url, timeout=600) as http,
        ):
            robot = http.post("/v1/robots", json={"name": "design-bench-large"}).json()["id"]
            for seed in (8, 9):  # each compute process's CasADi maps for 20 000 poses built once, as in service
                http.post(f"/v1/robots/{robot}/pose-designs", json=_body("D", 20_000, seed))
            rows["D, M = 20000"] = _through_api(http, robot, "D", 20_000)
    for name, row in rows.items():
        criterion, m = name.split(", M = ")
        row["library_s"] = _in_library(criterion, int(m))
    targets = [
        _sync_target(f"{criterion}: K=30 of M=2000", rows[f"{criterion}, M = 2000"], limit)
        for criterion, limit in TARGETS_S.items()
    ]
    targets.append(_sync_target(f"D: K=30 of M=20000 (budget {LARGE_BUDGET_S:g} s)", rows["D, M = 20000"], 5.0))
    return {**rows, "targets": targets, "markdown": _table(rows)}
