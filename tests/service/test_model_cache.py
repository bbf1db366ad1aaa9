"""The app's model cache: bounded, keyed by parameter version (a new version is read, never a stale one)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from service.compute.model_cache import ModelCache
from service.errors import NotFound
from service.persistence import Database, Repository
from service.persistence.lifecycle import Actor, Lifecycle
from service.schemas.robots import RobotCreate
from service.services.robots import create_robot


@pytest.fixture
def db(tmp_path: Path) -> Iterator[Database]:
    database = Database(f"sqlite:///{tmp_path}/cache.db")
    database.migrate()
    yield database
    database.dispose()


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_a_new_version_is_read_and_the_cache_stays_bounded(db: Database) -> None:
    cache = ModelCache(db, size=2)
    ids = [create_robot(db=db, body=RobotCreate(name=f"r{k}")).id for k in range(3)]
    _, nominal = cache.current(ids[0])
    assert cache.current(ids[0])[1] is nominal  # the same entry: no second read
    changed = nominal.copy()
    changed[0] += 1.0
    with db.session() as s:
        robot = Repository(s).robot(ids[0])
        Lifecycle(s).add_version(
            robot, values=changed.tolist(), std_errors=None, identifiable=None, provenance="test", actor=Actor()
        )
    np.testing.assert_array_equal(cache.current(ids[0])[1], changed)
    for robot_id in ids:
        cache.current(robot_id)
    assert len(cache) == 2
    with pytest.raises(NotFound):
        cache.current("nope")
