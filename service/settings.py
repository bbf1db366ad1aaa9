"""Service settings, from the environment (prefix `IWR_`, plus the conventional `DATABASE_URL`)."""

from __future__ import annotations

from pydantic import AliasChoices, Field
from pydantic_settings import BaseSettings, SettingsConfigDict

from service.http.security import ApiKey, parse_keys


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="IWR_", extra="ignore")

    database_url: str = Field(
        default="sqlite:///./data/iwr.db",
        validation_alias=AliasChoices("DATABASE_URL", "IWR_DATABASE_URL"),
        description="SQLAlchemy URL; postgresql+psycopg://user@host:5432/db for PostgreSQL.",
    )
    api_keys: str = Field(
        default="",
        description="Comma-separated `name:scope:sha256hex` entries, or bare keys (write scope); see "
        "service.http.security.",
    )
    # --- hardening (service.http.security, service.compute.limits)
    api_keys_file: str | None = Field(default=None, description="JSON list of {name, scope, sha256} keys.")
    metrics_public: bool = Field(default=False, description="/metrics without a key (else a read key, with keys).")
    docs_public: bool = Field(default=True, description="/docs and /openapi.json without a key.")
    max_body_bytes: int = Field(default=20_000_000, description="Larger request bodies get 413.")
    sync_budget_seconds: float = Field(
        default=2.0,
        gt=0,
        description="Estimated seconds of work a synchronous request may ask for; above it a calibration or a design "
        "is refused with 422 saying to send it with ?async=true (a job), other work saying to send less. "
        "`python -m service` sets the compute deadline to 2.5x it unless IWR_COMPUTE_DEADLINE_SECONDS is given.",
    )
    compute_deadline_seconds: float | None = Field(
        default=None,
        gt=0,
        description="A synchronous computation still running after this is stopped where it can be and answered "
        "503 (none: no deadline). `python -m service` defaults it to 2.5x `sync_budget_seconds` (5 s).",
    )
    parse_deadline_seconds: float = Field(
        default=15.0,
        gt=0,
        description="A large body still being read (parsed and checked in the parse process) after this is "
        "refused with 422 and its process replaced, so the bodies behind it are not held (a 20 MB calibration, the "
        "largest body the limit admits, is read in ~0.8 s here).",
    )
    header_timeout_seconds: float = Field(
        default=10.0, gt=0, description="A request's line and headers within this, else 408 and closed."
    )
    body_timeout_seconds: float = Field(default=30.0, gt=0, description="A whole request body within this, else 408.")
    job_workers: int = Field(default=2, ge=0, description="Worker processes for ?async=true jobs (0: in-process).")
    compute_processes: int = Field(
        default=0,
        ge=0,
        description="Worker processes for synchronous computations (0: threads of the API process). "
        "`python -m service` defaults it to one per core (service.compute.pool).",
    )
    log_level: str = "INFO"
    warm_up: bool = Field(default=True, description="Build the CasADi Functions and solvers at start-up.")
    background_builds: bool = Field(
        default=True,
        description="Build a new robot's structure (native code, solvers, tables) in the background when the "
        "robot is created (service.compute.builds); off, its first request builds it.",
    )

    # ---- jobs (service/jobs): the engine, leases, retries, the queue's bound, time limits
    broker_url: str = Field(
        default="",
        description="Celery broker (amqp://guest:guest@host:5672// or redis://host:6379/0); empty: the embedded "
        "in-process pool of `job_workers` processes.",
    )
    job_queue: str = Field(default="iwr-jobs", description="The broker's queue of job ids (one per deployment).")
    job_lease_seconds: float = Field(
        default=10.0,
        gt=0,
        description="A running job's lease; its worker renews it every third of it. A worker silent this long is "
        "taken as stopped and its job requeued.",
    )
    job_max_attempts: int = Field(default=3, ge=1, description="Leases that may expire before a job is failed.")
    job_queue_limit: int = Field(default=1000, ge=1, description="Queued jobs beyond which submissions get 429.")
    job_retry_after: int = Field(default=5, ge=1, description="Retry-After (seconds) of that 429.")
    job_time_limit_calibration: float = Field(default=600.0, gt=0, description="Seconds a calibration job may run.")
    job_time_limit_pose_design: float = Field(default=1800.0, gt=0, description="Seconds a pose design may run.")
    worker_concurrency: int = Field(default=1, ge=1, description="Processes per `python -m service.worker`.")

    def time_limit(self, kind: str) -> float:
        return self.job_time_limit_pose_design if kind == "pose_design" else self.job_time_limit_calibration

    @property
    def keys(self) -> tuple[ApiKey, ...]:
        return parse_keys(self.api_keys, self.api_keys_file)


def get_settings() -> Settings:
    """Read once per application, by `create_app`, which keeps them on `app.state.settings`."""
    return Settings()
