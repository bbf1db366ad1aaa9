"""The robots' descriptions and current parameters, owned by the application (or a job worker) and injected.

Parameter versions are immutable, so once a (robot, version) has been seen a request needs only the one
indexed lookup of the current version number: the single-pose FK hot path reads no ORM row.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from models import RobotDescription
from models._types import Array
from service.conversions.robots import description
from service.conversions.terms import stored_model
from service.persistence import Database, Repository

Model = tuple[RobotDescription, Array]
T = TypeVar("T")


class ModelCache:
    """Bounded LRU of (robot id, version) → (description, parameters) over one database."""

    def __init__(self, db: Database, size: int = 256) -> None:
        self.db, self.size = db, size
        self._entries: OrderedDict[tuple[str, int], Model] = OrderedDict()
        self._conditions: OrderedDict[tuple[str, int], dict[str, Any] | None] = OrderedDict()
        self._derived: OrderedDict[tuple[str, int, str], Any] = OrderedDict()
        self._lock = threading.Lock()

    def current(self, robot_id: str) -> Model:
        version = self.db.current_version(robot_id)
        if version is not None:
            with self._lock:
                found = self._entries.get((robot_id, version))
                if found is not None:
                    self._entries.move_to_end((robot_id, version))
                    return found
        with self.db.reader() as s:
            repo = Repository(s)
            version = repo.current_version(robot_id)  # NotFound for an unknown robot
            values = np.asarray(repo.version(robot_id, version).values, dtype=float)
            # A version calibrated with model terms carries their values: its model is the robot with them.
            model = (stored_model(description(repo.robot(robot_id)), values.size), values)
        with self._lock:
            self._entries[(robot_id, version)] = model
            while len(self._entries) > self.size:
                self._entries.popitem(last=False)
        return model

    def conditions(self, robot_id: str) -> tuple[int, dict[str, Any] | None]:
        """The current version's number and what its campaign was measured under (None: no campaign made it);
        read only by requests that state conditions, so the hot path above never pays for it."""
        version = self.db.current_version(robot_id)
        if version is not None:
            with self._lock:
                if (robot_id, version) in self._conditions:
                    return version, self._conditions[(robot_id, version)]
        with self.db.reader() as s:
            repo = Repository(s)
            version = repo.current_version(robot_id)  # NotFound for an unknown robot
            stored = repo.version(robot_id, version).conditions
        with self._lock:
            self._conditions[(robot_id, version)] = stored
            while len(self._conditions) > self.size:
                self._conditions.popitem(last=False)
        return version, stored

    def derived(self, robot_id: str, what: str, build: Callable[[int], T]) -> T:
        """`build(version)` of the robot's current version, kept under `what` for that version: a version never
        changes, so what is derived from it (a calibration's covariance and measured region) is built once. A
        build that raises keeps nothing."""
        version = self.db.current_version(robot_id)
        if version is None:
            self.current(robot_id)  # NotFound for an unknown robot
            version = self.db.current_version(robot_id)
            assert version is not None
        key = (robot_id, version, what)
        with self._lock:
            if key in self._derived:
                self._derived.move_to_end(key)
                return self._derived[key]  # type: ignore[no-any-return]
        value = build(version)
        with self._lock:
            self._derived[key] = value
            while len(self._derived) > self.size:
                self._derived.popitem(last=False)
        return value

    def __len__(self) -> int:
        return len(self._entries)

    def clear(self) -> None:
        with self._lock:
            self._entries.clear()
            self._conditions.clear()
            self._derived.clear()
