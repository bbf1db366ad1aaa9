"""Run every benchmark module and write `benchmarks/results.json` and `docs/benchmarks.md`.

Each `benchmarks/bench_*.py` exposes `run() -> dict[str, object]`: a flat-ish
mapping of measurement names to numbers (seconds, ratios, ...) and a
`"targets"` list of `{"name", "value", "limit", "op", "met"}` records.
`python -m benchmarks name ...` runs only the named modules.
"""

from __future__ import annotations

import importlib
import json
import platform
import sys
import time
from pathlib import Path

from benchmarks.timing import markdown_table

ROOT = Path(__file__).resolve().parent
RESULTS = ROOT / "results.json"
REPORT = ROOT.parent / "docs" / "benchmarks.md"


def _modules(selected: list[str]) -> list[str]:
    names = sorted(p.stem for p in ROOT.glob("bench_*.py"))
    if selected:
        names = [n for n in names if n.removeprefix("bench_") in selected or n in selected]
    return names


def _markdown(results: dict[str, dict[str, object]]) -> str:
    lines = [
        "# Benchmark results",
        "",
        f"Machine: {platform.machine()}, Python {platform.python_version()}.",
        "",
    ]
    for name, res in results.items():
        lines += [f"## {name.removeprefix('bench_')}", ""]
        targets = res.get("targets", [])
        if isinstance(targets, list) and targets:
            rows = [
                [t["name"], f"{t['value']:.4g}", f"{t['op']} {t['limit']:.4g}", "yes" if t["met"] else "NO"]
                for t in targets
            ]
            lines += [*markdown_table(["measurement", "value", "target", "met"], rows), ""]
        markdown = res.get("markdown")
        if isinstance(markdown, list):
            lines += [*markdown, ""]
        other = {k: v for k, v in res.items() if k not in {"targets", "markdown"}}
        if other:
            lines += ["```json", json.dumps(other, indent=1, default=float), "```", ""]
    return "\n".join(lines)


def main(argv: list[str]) -> int:
    results: dict[str, dict[str, object]] = {}
    if RESULTS.exists():
        results = json.loads(RESULTS.read_text())
    for name in _modules(argv):
        started = time.perf_counter()
        print(f"== {name}", flush=True)
        module = importlib.import_module(f"benchmarks.{name}")
        res = module.run()
        res["wall_seconds"] = round(time.perf_counter() - started, 3)
        results[name] = res
        print(json.dumps(res, indent=1, default=float), flush=True)
        RESULTS.write_text(json.dumps(results, indent=1, default=float))
    REPORT.parent.mkdir(exist_ok=True)
    REPORT.write_text(_markdown(dict(sorted(results.items()))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
