"""`/readyz` tells the truth about what the API needs (issue 48: it said 200 while the broker was down): the
database, and the job broker when jobs run on Celery, each named in the 503 while it does not answer. The
broker is a Redis of the test's own (tests/service/test_broker_restart.py's `OwnRedis`), killed and started
again on the same port."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.service.conftest import fresh_sqlite, make_client
from tests.service.test_broker_restart import OwnRedis, redis  # noqa: F401  (the fixture, used by name)

pytestmark = pytest.mark.slow  # a Redis started and killed: ~2 s


@pytest.fixture
def database(tmp_path: Path, migrated_sqlite: Path) -> Iterator[str]:
    yield fresh_sqlite(migrated_sqlite, tmp_path)


def test_readyz_names_the_broker_while_it_is_down(database: str, redis: OwnRedis) -> None:  # noqa: F811
    with make_client(database, broker_url=redis.url) as client:
        assert client.get("/readyz").status_code == 200
        redis.kill()
        down = client.get("/readyz")
        assert down.status_code == 503, down.text
        problem = down.json()
        assert "job broker" in problem["detail"] and str(redis.port) in problem["detail"]
        assert "database" not in problem["detail"]  # only what fails is named
        assert client.get("/healthz").status_code == 200  # the process is up all the same
        redis.start()
        assert client.get("/readyz").status_code == 200  # ready again, without a restart


def test_readyz_without_a_broker_asks_only_the_database(database: str) -> None:
    with make_client(database) as client:
        assert client.get("/readyz").json() == {"status": "ready"}
