"""What `make bench` runs: one module per area, each exposing `run() -> dict`."""
