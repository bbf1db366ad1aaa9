"""The dependency direction `service → optimal_design → models`, and the seams inside them.

The contracts live in pyproject.toml (`[tool.importlinter]`, also run by `make lint` as `lint-imports`);
this test makes a plain `pytest` enforce them too. import-linter follows indirect imports, which the
AST scan this test used to be could not (`models` core → a module → `models.identification`).
"""

from __future__ import annotations

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
    assert contracts["layers"]["layers"] == ["service", "optimal_design", "models"]
    forbidden = {
        tuple(c["source_modules"]): set(c["forbidden_modules"]) for c in config["contracts"] if c["type"] == "forbidden"
    }
    assert {"service.routes", "fastapi"} <= forbidden[("service.persistence",)]
    assert {"fastapi", "sqlalchemy", "pydantic"} <= forbidden[("models", "optimal_design")]
