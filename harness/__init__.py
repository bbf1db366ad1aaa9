"""What the tests and the benchmarks both drive: a live `python -m service` (live.py), an API + Celery worker
fleet (fleet.py) and simulated campaigns in the API's units (records.py). Its own package so that
`benchmarks/` never imports `tests/`; the service packages never import it (an import-linter contract)."""
