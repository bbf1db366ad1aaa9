"""Schemathesis on PostgreSQL as well as SQLite, and its stateful phase (links inferred from the schema: create a
robot, then read it, its parameters, its calibrations; create a design, read it...). `make fuzz` runs it longer.

The examples per operation come from IWR_FUZZ_EXAMPLES (read at import, like the other test knobs): the default
keeps `make test` short; `make fuzz` sets 150.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from typing import Any

import pytest
import schemathesis
from fastapi import FastAPI
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, Phase, settings
from schemathesis import GenerationMode
from schemathesis.checks import not_a_server_error
from schemathesis.schemas import BaseSchema
from schemathesis.specs.openapi.checks import content_type_conformance, response_schema_conformance

from service.http.app import create_app
from service.persistence import Database
from service.persistence.tables import Base
from service.settings import Settings
from tests.service.conftest import POSTGRES_ADMIN
from tests.service.contract_schema import asgi_schema

# The whole module is `make test`'s (~15 s of CPU here); test_contract.py runs every operation on SQLite.
pytestmark = pytest.mark.slow

EXAMPLES = int(os.environ.get("IWR_FUZZ_EXAMPLES", "2"))
"""Per operation on PostgreSQL in `make test`: what this module adds to test_contract.py's random bodies on SQLite
is the database's own behaviour (its integer columns, constraints, transactions), which the coverage phase's valid
requests and two random ones reach; 4 cost 46 s of CPU on 2026-12-07's 60 operations (`make fuzz` runs 150)."""
STEPS = int(os.environ.get("IWR_FUZZ_STEPS", "6"))
CHECKS = [not_a_server_error, response_schema_conformance, content_type_conformance]
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), database=None)

# As in test_contract.py, the schemas are read from the apps when the tests run, in the worker that runs them (not at
# import, in every pytest-xdist worker), and each operation is a subtest of the test that runs it.
SLOW = "/v1/error-analysis"
"""The one slow operation (error analysis, ~3 s an example) is covered by test_contract.py; here it would only spend
the budget."""


def _app(database_url: str) -> FastAPI:
    return create_app(
        Settings(database_url=database_url, warm_up=False, background_builds=False, job_workers=0, log_level="ERROR")
    )


@pytest.fixture(scope="module")
def postgres_app() -> Iterator[TestClient]:
    import psycopg

    name = f"iwr_fuzz_{uuid.uuid4().hex[:12]}"
    try:
        with psycopg.connect(POSTGRES_ADMIN, autocommit=True, connect_timeout=3) as admin:
            admin.execute(f'CREATE DATABASE "{name}"')
    except psycopg.OperationalError as exc:
        if os.environ.get("CI") == "true":
            pytest.fail(f"PostgreSQL must be running for CI on this machine: {exc}")
        pytest.skip(f"PostgreSQL is not reachable at {POSTGRES_ADMIN}: {exc}")
    try:
        with TestClient(_app(f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}")) as client:
            client.post("/v1/robots", json={"name": "fuzz"})
            yield client
        _close_last_database(client)
    finally:
        with psycopg.connect(POSTGRES_ADMIN, autocommit=True, connect_timeout=3) as admin:
            admin.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def _close_last_database(client: TestClient) -> None:
    """The app's last Database, whichever lifespan made it (schemathesis starts one per test on this app, and a
    call after a lifespan ended opens connections in a fresh pool of its disposed engine): closed here, by the
    fixture, not collected open in some later test (issue 48: `iwr_fuzz_…`'s connection, a ResourceWarning that
    failed test_limits.py)."""
    db = getattr(client.app.state, "db", None)  # type: ignore[attr-defined]
    if isinstance(db, Database):
        db.dispose()


@pytest.fixture(scope="module")
def sqlite_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    # Under pytest's temporary directory (cleaned by pytest), not a mkdtemp nobody removed.
    with TestClient(_app(f"sqlite:///{tmp_path_factory.mktemp('fuzz') / 'fuzz.db'}")) as client:
        client.post("/v1/robots", json={"name": "fuzz"})
        yield client
    _close_last_database(client)


def _schema(client: TestClient) -> BaseSchema:
    return asgi_schema(client.app)


@pytest.fixture(scope="module")
def postgres_schema(postgres_app: TestClient) -> BaseSchema:
    schema = _schema(postgres_app)
    # Schemathesis' coverage phase here only with valid requests (boundary values, long strings: what reaches the
    # database's columns); its invalid ones (missing fields, wrong types) are refused by validation before any
    # database is touched, and test_contract.py sends them all on SQLite. They were half of this test's ~20 s.
    schema.config.phases.coverage.generation.modes = [GenerationMode.POSITIVE]
    return schema


# One item runs every operation (each a subtest): 15 min, not the run's 300 s per test (it took 4 min 16 s of wall at
# load ~9, issue 48).
# Not traced by coverage, as test_contract.py's test_api_contract (Python-heavy; the API tests measure this code).
@pytest.mark.no_cover
@pytest.mark.timeout(900)
@schemathesis.pytest.from_fixture("postgres_schema").exclude(path=SLOW).parametrize()
@SETTINGS
def test_api_contract_on_postgresql(case: schemathesis.Case[Any]) -> None:
    """What found the 2^31 version and the NUL characters: PostgreSQL's types are narrower than SQLite's."""
    case.call_and_validate(checks=CHECKS)


def _empty(database_url: str) -> None:
    """Delete every row, through a Database of our own, disposed at once.

    Not through `app.state.db`: schemathesis runs the app's lifespan once per test (and ends it at the test's
    teardown), and each run replaces `app.state.db`, so before the test's first call it names the previous
    test's Database, already disposed. A session on it opened a connection in a fresh pool that nobody would
    close: the psycopg ResourceWarning ("deleted while still open") seen in later tests, traced here.
    """
    db = Database(database_url)
    try:
        with db.session() as s:
            for table in reversed(Base.metadata.sorted_tables):
                s.execute(table.delete())
    finally:
        db.dispose()  # the connection is checked in by then: dispose closes it


def _machine(schema: Any, app: Any) -> Any:
    base = schema.exclude(path=SLOW).as_state_machine()

    class Machine(base):  # type: ignore[misc, valid-type]
        def __init__(self) -> None:
            # Each sequence from an empty database, the first one too: hypothesis remembers the draws behind
            # every prefix it ran, and a list read that answers differently for the same requests (what the
            # fixture or the module's other tests stored, what an earlier sequence created) fails the run as a
            # flaky strategy. Seen once: `GET /v1/robots -> DELETE` drew an integer, then a string.
            _empty(app.state.settings.database_url)
            super().__init__()

        def before_call(self, case: schemathesis.Case[Any], **kwargs: Any) -> None:
            # A generated key repeated across examples would replay (or refuse) instead of run: the sequence's
            # answers would depend on earlier examples, which hypothesis reports as a flaky strategy.
            if case.headers:
                case.headers.pop("Idempotency-Key", None)

        def validate_response(self, response: Any, case: schemathesis.Case[Any], **kwargs: Any) -> None:
            case.validate_response(response, checks=CHECKS)

    return Machine


STATEFUL = os.environ.get("IWR_FUZZ_STATEFUL", "postgres").split(",")
"""The databases the stateful phase runs on: PostgreSQL in `make test` (its sequences reach what SQLite's do, and
the narrower types as well; SQLite's took 16 s of CPU beside PostgreSQL's 38), both in `make fuzz`."""


@pytest.mark.no_cover  # Python-heavy generation, as test_api_contract (test_contract.py)
@pytest.mark.timeout(900)  # ~40 s of CPU on PostgreSQL: one of the longest items, run first (tests/conftest.py)
@pytest.mark.parametrize("database", STATEFUL)
def test_stateful(database: str, request: pytest.FixtureRequest) -> None:
    client = request.getfixturevalue(f"{database}_app")
    machine = _machine(_schema(client), client.app)
    links = [name for name in dir(machine) if "POST_v1_robots___201" in name]
    assert len(links) >= 5, "the create -> read links were not inferred: the stateful phase would test nothing"
    machine.run(
        settings=settings(
            max_examples=EXAMPLES * 3,
            stateful_step_count=STEPS,
            deadline=None,
            suppress_health_check=list(HealthCheck),
            database=None,
            # No shrinking: a replayed sequence meets the records the first run left (a robot's name taken),
            # so hypothesis would report a flaky strategy instead of the failure itself.
            phases=[Phase.explicit, Phase.generate],
        )
    )
