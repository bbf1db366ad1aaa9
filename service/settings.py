"""Service settings, from the environment (prefix `IWR_`, plus the conventional `DATABASE_URL`)."""

from __future__ import annotations

from pydantic import AliasChoices, Field
from pydantic_settings import BaseSettings, SettingsConfigDict

from service.security import ApiKey, parse_keys


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="IWR_", extra="ignore")

    database_url: str = Field(
        default="sqlite:///./data/iwr.db",
        validation_alias=AliasChoices("DATABASE_URL", "IWR_DATABASE_URL"),
        description="SQLAlchemy URL; postgresql+psycopg://user@host:5432/db for PostgreSQL.",
    )
    api_keys: str = Field(
        default="",
        description="Comma-separated `name:scope:sha256hex` entries, or bare keys (write scope); see service.security.",
    )
    # --- hardening (service.security, service.limits)
    api_keys_file: str | None = Field(default=None, description="JSON list of {name, scope, sha256} keys.")
    metrics_public: bool = Field(default=False, description="/metrics without a key (else a read key, with keys).")
    docs_public: bool = Field(default=True, description="/docs and /openapi.json without a key.")
    max_body_bytes: int = Field(default=20_000_000, description="Larger request bodies get 413.")
    job_workers: int = Field(default=2, ge=0, description="Worker processes for ?async=true jobs (0: in-process).")
    log_level: str = "INFO"
    warm_up: bool = Field(default=True, description="Build the CasADi Functions and solvers at start-up.")

    @property
    def keys(self) -> tuple[ApiKey, ...]:
        return parse_keys(self.api_keys, self.api_keys_file)


def get_settings() -> Settings:
    """Read once per application, by `create_app`, which keeps them on `app.state.settings`."""
    return Settings()
