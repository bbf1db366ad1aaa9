"""Background jobs: the database row is the truth; a process pool does the work."""

from service.jobs.runner import JobRunner, execute_job

__all__ = ["JobRunner", "execute_job"]
