"""Persistence: SQLAlchemy 2 tables, repository, engine and Alembic migrations."""

from service.persistence.database import Database
from service.persistence.repository import Repository

__all__ = ["Database", "Repository"]
