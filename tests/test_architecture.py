"""The dependency direction `service → optimal_design → models`, and the seams inside them.

The contracts live in pyproject.toml (`[tool.importlinter]`, also run by `make lint` as `lint-imports`);
this test makes a plain `pytest` enforce them too. import-linter follows indirect imports, which the
AST scan this test used to be could not (`models` core → a module → `models.identification`).
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import pytest
from importlinter.cli import EXIT_STATUS_SUCCESS, lint_imports

ROOT = Path(__file__).resolve().parent.parent


def test_import_contracts_are_kept(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.chdir(ROOT)
    assert lint_imports(config_filename=str(ROOT / "pyproject.toml"), cache_dir=str(tmp_path)) == EXIT_STATUS_SUCCESS


def test_the_layers_named_in_the_plan_have_contracts() -> None:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["importlinter"]
    contracts = {c["type"]: c for c in config["contracts"] if c["type"] == "layers"}
    assert contracts["layers"]["layers"] == ["service", "optimal_design | programs", "models"]
    forbidden = {
        tuple(c["source_modules"]): set(c["forbidden_modules"]) for c in config["contracts"] if c["type"] == "forbidden"
    }
    assert {"service.routes", "fastapi"} <= forbidden[("service.persistence",)]
    assert {"fastapi", "sqlalchemy", "pydantic"} <= forbidden[("models", "optimal_design", "programs")]


def _imported(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


@pytest.mark.parametrize("package", ["benchmarks", "harness"])
def test_benchmarks_and_the_harness_never_import_the_tests(package: str) -> None:
    """`python -m benchmarks` runs outside pytest: importing tests/ would tie it to test modules that move and to
    pytest itself, so what both need lives in harness/. import-linter checks only its root packages, hence a scan."""
    files = sorted((ROOT / package).rglob("*.py"))
    assert files, f"{package}/ has no modules"
    offending = {
        str(f.relative_to(ROOT)): sorted(n for n in _imported(f) if n == "tests" or n.startswith("tests."))
        for f in files
    }
    assert not {f: names for f, names in offending.items() if names}
