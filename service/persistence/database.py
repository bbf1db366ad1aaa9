"""Engine, sessions and schema migrations (Alembic, run at start-up)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, create_engine, event, text
from sqlalchemy.engine import make_url
from sqlalchemy.exc import DBAPIError, InterfaceError, OperationalError
from sqlalchemy.orm import Session, sessionmaker

from service.errors import DatabaseUnavailable

MIGRATIONS = Path(__file__).resolve().parent.parent / "migrations"


RETRY_AFTER_S = 5
"""Retry-After of a request the database could not serve: a restart or fail-over takes seconds."""
CONNECT_TIMEOUT_S = 5
"""PostgreSQL: a server that does not answer the connection (a dropped route, a host down) fails it after this,
instead of holding the request until the kernel gives up (minutes)."""


@contextmanager
def _available() -> Iterator[None]:
    """The database's connection-level failures as `DatabaseUnavailable` (a 503 with Retry-After), not a 500:
    a refused or dropped connection (PostgreSQL restarted, the network gone), SQLite locked past its timeout or
    its disk full. Errors of the statement itself (an IntegrityError) are left to the caller."""
    try:
        yield
    except DBAPIError as exc:
        if not (exc.connection_invalidated or isinstance(exc, OperationalError | InterfaceError)):
            raise
        reason = str(exc.orig).strip().splitlines()[0] if exc.orig is not None else type(exc).__name__
        raise DatabaseUnavailable(
            f"the database cannot serve this request now ({reason}); retry in {RETRY_AFTER_S} s",
            retry_after=RETRY_AFTER_S,
        ) from exc


class Database:
    def __init__(self, url: str) -> None:
        self.url = url
        parsed = make_url(url)
        kwargs: dict[str, Any] = {"pool_pre_ping": True}
        if parsed.get_backend_name() == "sqlite":
            if parsed.database and parsed.database != ":memory:":
                Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
            # pysqlite's own transaction handling off, so that `begin` below decides how transactions start.
            kwargs["connect_args"] = {"check_same_thread": False, "timeout": 30, "isolation_level": None}
        else:
            kwargs |= {"pool_size": 10, "max_overflow": 20, "connect_args": {"connect_timeout": CONNECT_TIMEOUT_S}}
        self.engine: Engine = create_engine(url, **kwargs)
        self.read_engine: Engine = self.engine
        if parsed.get_backend_name() == "sqlite":
            # Readers on their own engine: in WAL mode they never wait for the writer.
            self.read_engine = create_engine(url, **kwargs)
            event.listen(self.read_engine, "connect", _sqlite_pragmas)
            event.listen(self.engine, "connect", _sqlite_pragmas)
            event.listen(self.engine, "begin", _sqlite_begin)
        self.sessions = sessionmaker(self.engine, expire_on_commit=False)
        self.read_sessions = sessionmaker(self.read_engine, expire_on_commit=False)

    def migrate(self) -> None:
        # Alembic loads here (0.4 s): the API's start-up migrates, its compute and job processes never do.
        from alembic import command  # noqa: PLC0415
        from alembic.config import Config  # noqa: PLC0415

        config = Config()
        config.set_main_option("script_location", str(MIGRATIONS))
        config.set_main_option("sqlalchemy.url", self.url.replace("%", "%%"))
        with self.engine.begin() as connection:
            config.attributes["connection"] = connection
            command.upgrade(config, "head")

    @contextmanager
    def session(self) -> Iterator[Session]:
        """One transaction: committed when the block succeeds, rolled back otherwise."""
        with _available(), self.sessions() as session, session.begin():
            yield session

    @contextmanager
    def reader(self) -> Iterator[Session]:
        """A read-only transaction (on SQLite: no write lock)."""
        with _available(), self.read_sessions() as session, session.begin():
            yield session

    def current_version(self, robot_id: str) -> int | None:
        """The robot's current parameter version, by one indexed lookup without the ORM (hot path)."""
        with _available(), self.read_engine.connect() as connection:
            found = connection.execute(
                text("SELECT current_version FROM robots WHERE id = :id"), {"id": robot_id}
            ).scalar()
        return None if found is None else int(found)

    def ping(self) -> bool:
        try:
            with self.engine.connect() as connection:
                connection.execute(text("SELECT 1"))
            return True
        except Exception:  # readiness reports any failure as "not ready"
            return False

    def dispose(self) -> None:
        self.engine.dispose()
        self.read_engine.dispose()


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA foreign_keys=ON")
    cursor.execute("PRAGMA journal_mode=WAL")
    # In WAL mode NORMAL still survives any crash of the process; only an OS crash or power loss can drop
    # the last commits, and it saves an fsync per transaction.
    cursor.execute("PRAGMA synchronous=NORMAL")
    cursor.execute("PRAGMA busy_timeout=30000")
    cursor.close()


def _sqlite_begin(connection: Any) -> None:
    # Take the write lock up front: a deferred transaction that reads, then writes, fails outright in WAL mode
    # when another writer committed in between, instead of waiting its turn. Transactions here are short
    # (computations run outside them), so serialising them costs little.
    connection.exec_driver_sql("BEGIN IMMEDIATE")
