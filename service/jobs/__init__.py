"""Background jobs: the database row is the truth; the embedded pool or Celery workers do the work."""

from service.jobs.runner import JobRunner, Outcome, Requeuing, WorkerContext, execute_job

__all__ = ["JobRunner", "Outcome", "Requeuing", "WorkerContext", "execute_job"]
