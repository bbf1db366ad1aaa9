"""The image, built and run for real with podman (`shared/guides/containers.md`): an API container and a worker
container from it, on this machine's PostgreSQL and RabbitMQ (host network), run a calibration job, and
both evaluate the batch Functions from the compiled library the build stage made (not CasADi's VM)."""

from __future__ import annotations

import shutil
import subprocess
import time
import urllib.request
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from harness.fleet import RABBITMQ, call, campaign, wait_for
from harness.live import ROOT, free_port
from tests.service.conftest import postgres_url
from tests.service.helpers import broker

BASE_IMAGE = "docker.io/library/python:3.11-slim-bookworm"
IMAGE = "localhost/iwr-calibration:test"
# The flags this machine needs (see the guide): runc (crun refuses the cgroup layout), limits the sandbox allows.
PODMAN = ["podman", "--runtime", "runc"]
LIMITS = ["--ulimit", "nofile=1024:1024", "--ulimit", "nproc=1024:1024"]


def _podman() -> None:
    if shutil.which("podman") is None:
        pytest.skip("podman is not installed (apt-get install podman runc): the image cannot be built here")
    if subprocess.run(["podman", "image", "exists", BASE_IMAGE], check=False).returncode != 0:
        pytest.skip(f"the base image {BASE_IMAGE} is not in podman's store (see shared/guides/containers.md)")


@pytest.fixture(scope="module")
def image() -> str:
    """Built once per run; podman's layer cache (and the base image, never removed) makes a rebuild short."""
    _podman()
    mounts = []
    for host in ("/etc/ssl/certs/ca-certificates.crt", "/etc/pip.conf"):  # TLS is inspected; the host's index
        if Path(host).exists():
            mounts += ["-v", f"{host}:{host}:ro"]
    build = subprocess.run(
        [
            *PODMAN,
            "build",
            "--pull=never",
            "--network=host",
            *mounts,
            *LIMITS,
            "-f",
            "docker/Dockerfile",
            "-t",
            IMAGE,
            ".",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=1500,
    )
    assert build.returncode == 0, build.stdout[-3000:] + build.stderr[-3000:]
    return IMAGE


@pytest.fixture
def pg() -> Iterator[str]:
    yield from postgres_url()


def _run(name: str, env: dict[str, str], *command: str) -> None:
    flags = [f"--env={k}={v}" for k, v in env.items()]
    started = subprocess.run(
        [*PODMAN, "run", "-d", "--name", name, "--network=host", *LIMITS, *flags, IMAGE, *command],
        capture_output=True,
        text=True,
        check=False,
    )
    assert started.returncode == 0, started.stderr


def _logs(name: str) -> str:
    found = subprocess.run([*PODMAN, "logs", name], capture_output=True, text=True, check=False)
    return found.stdout + found.stderr


@pytest.mark.slow  # the image build (~2 min cold, seconds cached) and two containers
def test_the_image_runs_a_calibration_job_through_an_api_and_a_worker_with_compiled_functions(
    image: str, pg: str
) -> None:
    port, tag = free_port(), uuid.uuid4().hex[:8]
    env = {
        "DATABASE_URL": pg,
        "IWR_BROKER_URL": broker(RABBITMQ),
        "IWR_JOB_QUEUE": f"iwr-image-{tag}",
        "IWR_JOB_LEASE_SECONDS": "5",
    }
    api, worker = f"iwr-api-{tag}", f"iwr-worker-{tag}"
    try:
        _run(api, env, "python", "-m", "service", "--host", "127.0.0.1", "--port", str(port))
        _run(worker, env, "python", "-m", "service.worker")
        base = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 120
        while True:
            try:
                if call(base, "GET", "/readyz")[0] == 200:
                    break
            except OSError:
                pass
            assert time.monotonic() < deadline, _logs(api)[-3000:]
            time.sleep(0.5)
        status, robot = call(base, "POST", "/v1/robots", {"name": "cell"})
        assert status == 201
        status, accepted = call(base, "POST", f"/v1/robots/{robot['id']}/calibrations?async=true", campaign(60))
        assert status == 202, accepted
        job = wait_for(base, [accepted["job_id"]], timeout=180)[accepted["job_id"]]
        assert job["status"] == "succeeded", (job, _logs(worker)[-3000:])
        assert job["result"]["parameter_version"] == 2
        # Compiled, not the VM: the API says so in /metrics, the worker in its start-up line.
        with urllib.request.urlopen(base + "/metrics", timeout=5) as r:
            metrics = r.read().decode()
        assert "iwr_native_functions 1.0" in metrics, [m for m in metrics.splitlines() if "native" in m]
        assert "runtime built" in _logs(worker) and "compiled Functions" in _logs(worker), _logs(worker)[-3000:]
        assert "CasADi VM" not in _logs(worker)
    finally:
        for name in (api, worker):
            subprocess.run([*PODMAN, "rm", "-f", "-t", "5", name], capture_output=True, check=False)
