"""Prometheus metrics, in a registry per application (tests create many apps)."""

from __future__ import annotations

from collections import Counter as Tally
from collections.abc import Iterator
from dataclasses import dataclass, field

from prometheus_client import CollectorRegistry, Counter, Gauge, Histogram
from prometheus_client.core import CounterMetricFamily
from prometheus_client.registry import Collector

from models.engine.native import VmReason, vm_only_structures


class VmOnlyStructures(Collector):
    """`iwr_vm_only_structures_total{reason}`: structures this process evaluates on CasADi's VM (no compiled
    library and no compiler in the container, compilation off, or a failed compilation), read from
    `models.engine.native` at each scrape. It only grows: a structure is built once per process."""

    def collect(self) -> Iterator[CounterMetricFamily]:
        family = CounterMetricFamily(
            "iwr_vm_only_structures",
            "Structures whose Functions run on CasADi's virtual machine (5-10x slower), by reason",
            labels=["reason"],
        )
        tally = Tally(vm_only_structures().values())
        for reason in VmReason:
            family.add_metric([reason.value], float(tally[reason]))
        yield family


@dataclass
class Metrics:
    registry: CollectorRegistry = field(default_factory=CollectorRegistry)

    def __post_init__(self) -> None:
        self.requests = Counter(
            "iwr_http_requests", "HTTP requests", ["method", "route", "status"], registry=self.registry
        )
        self.latency = Histogram(
            "iwr_http_request_seconds",
            "HTTP request latency",
            ["method", "route"],
            buckets=(0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 30, 60),
            registry=self.registry,
        )
        self.solve = Histogram(
            "iwr_solve_seconds",
            "Computation time by kind (identification, design, inverse kinematics)",
            ["kind"],
            buckets=(0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 30, 60, 120),
            registry=self.registry,
        )
        self.queue = Gauge("iwr_jobs", "Jobs by status", ["status"], registry=self.registry)
        # From the job rows at each scrape, so every API replica reports the whole system's jobs, whichever
        # process or machine ran them.
        self.queue_depth = Gauge("iwr_jobs_queue_depth", "Jobs waiting for a worker", registry=self.registry)
        self.running = Gauge("iwr_jobs_running", "Jobs a worker holds now", registry=self.registry)
        self.job_seconds = Gauge(
            "iwr_job_duration_seconds_total",
            "Run time of succeeded jobs, summed, by kind",
            ["kind"],
            registry=self.registry,
        )
        self.job_count = Gauge("iwr_jobs_succeeded", "Succeeded jobs by kind", ["kind"], registry=self.registry)
        self.native = Gauge(
            "iwr_native_functions",
            "1 when this process evaluates the batch Functions from a compiled library, 0 in CasADi's VM",
            registry=self.registry,
        )
        self.registry.register(VmOnlyStructures())
