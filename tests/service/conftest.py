"""Apps on a fresh SQLite file, and on a fresh PostgreSQL database when the server answers."""

from __future__ import annotations

import os
import shutil
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from harness.programs import Cell, ur5_cell
from models import Registry
from service.http.app import create_app
from service.persistence import Database
from service.settings import Settings
from tests.service.contract_check import ContractClient, committed
from tests.service.helpers import ur5_with_truth

POSTGRES_ADMIN = os.environ.get("IWR_TEST_POSTGRES", "postgresql://postgres@127.0.0.1:5432/postgres")


def postgres_url() -> Iterator[str]:
    """A new, empty PostgreSQL database for one test module; dropped afterwards."""
    psycopg = pytest.importorskip("psycopg")
    try:
        admin = psycopg.connect(POSTGRES_ADMIN, autocommit=True, connect_timeout=3)
    except psycopg.OperationalError as exc:
        if os.environ.get("CI") == "true":
            pytest.fail(f"PostgreSQL must be running for CI on this machine: {exc}")
        pytest.skip(f"PostgreSQL is not reachable at {POSTGRES_ADMIN}: {exc}")
    name = f"iwr_test_{uuid.uuid4().hex[:12]}"
    admin.execute(f'CREATE DATABASE "{name}"')
    try:
        yield f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    finally:
        admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
        admin.close()


@pytest.fixture(scope="session")
def migrated_sqlite(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A SQLite database migrated once per process; each test gets a copy (`fresh_sqlite`). Migrating a new file
    costs 30-170 ms here, a copy under 1 ms, and the app's own migrate at start-up then finds it at head."""
    path = tmp_path_factory.mktemp("template") / "iwr.db"
    database = Database(f"sqlite:///{path}")
    database.migrate()
    database.dispose()
    return path


def fresh_sqlite(template: Path, directory: Path) -> str:
    """The URL of a copy of the migrated `template` in `directory` (with any sidecar file SQLite left)."""
    for source in template.parent.glob(template.name + "*"):
        shutil.copyfile(source, directory / source.name)
    return f"sqlite:///{directory / template.name}"


# The PostgreSQL variants are `slow`: each makes and migrates a database (1-2 s of set-up) for a test SQLite
# already runs; `make test` runs both, `make test-fast` SQLite only.
@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.slow)])
def database_url(request: pytest.FixtureRequest, tmp_path: Path, migrated_sqlite: Path) -> Iterator[str]:
    if request.param == "sqlite":
        yield fresh_sqlite(migrated_sqlite, tmp_path)
    else:
        yield from postgres_url()


@pytest.fixture
def db(database_url: str) -> Iterator[Database]:
    """A migrated database on SQLite (and on PostgreSQL in `make test`), for tests below the HTTP layer."""
    database = Database(database_url)
    database.migrate()
    yield database
    database.dispose()


def make_client(url: str, registry: Registry | None = None, **settings: object) -> ContractClient:
    """Every response it receives is checked against the committed OpenAPI document (`contract_check`). With
    `registry` (the session's), the app uses it; without, it builds its own, empty (warm_up is off)."""
    # No background builds (service.compute.builds): a test's robot builds what its own requests use, as before.
    options: dict[str, object] = {
        "database_url": url,
        "job_workers": 0,
        "warm_up": False,
        "background_builds": False,
        "log_level": "WARNING",
    }
    options.update(settings)
    app = create_app(Settings(**options), registry=registry)  # type: ignore[arg-type]
    return ContractClient(app, committed())


@pytest.fixture
def client(tmp_path: Path, registry: Registry, migrated_sqlite: Path) -> Iterator[TestClient]:
    with make_client(fresh_sqlite(migrated_sqlite, tmp_path), registry) as c:
        yield c
    assert c.contract.checked > 0, "the test's responses went unchecked"


@pytest.fixture(scope="module")
def api(tmp_path_factory: pytest.TempPathFactory, migrated_sqlite: Path, registry: Registry) -> Iterator[TestClient]:
    """One app for a whole module, on a copy of the migrated SQLite file: for modules whose tests share what they
    build (a tree's chains, a calibrated robot) and keep their robots apart by name. A module that wants its own
    `api` (an app per test, on each database) defines it."""
    with make_client(fresh_sqlite(migrated_sqlite, tmp_path_factory.mktemp("module")), registry) as client:
        yield client


@pytest.fixture(scope="module")
def cell() -> Cell:
    """The UR5-like cell the program tests teach their targets in and run them on (harness.programs)."""
    return ur5_cell()


@pytest.fixture
def ur5(client: TestClient, cell: Cell) -> str:
    """A UR5-like robot whose version 2 is the `cell`'s truth: what the program tests compensate with."""
    return ur5_with_truth(client, cell)


@pytest.fixture
def robot_id(client: TestClient) -> str:
    response = client.post("/v1/robots", json={"name": "cell-3"})
    assert response.status_code == 201
    return str(response.json()["id"])
