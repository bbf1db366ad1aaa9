"""A new robot's structure is built in the background when the robot is created (service.compute.builds), and the robot
says how far that build is: the answer to POST does not wait for it, and the first request afterwards finds it
done instead of compiling."""

from __future__ import annotations

import os
import subprocess
import sys
import time
import uuid
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np
import pytest

from harness.live import ROOT
from models import Registry, RobotDescription, iwr
from models.description.structure import description_from_document
from models.engine.native import compiler_available
from models.engine.runtime import structure_tag
from models.warm import warm_everything
from service.compute import builds
from service.compute.builds import BuildState, StructureBuilds
from tests.service.conftest import make_client

SLOW_BUILD_S = 3.0
"""How long the slowed build takes, at least: over any POST's answer here, loaded or not."""


def _unique_arm() -> dict[str, Any]:
    """A 3R arm no other test's registry has: its lengths carry a random fraction. (Its compiled libraries may
    well be in the disk cache: the lengths are the Functions' inputs.)"""
    a = 100.0 + uuid.uuid4().int % 10_000 / 1e4
    links = [
        {"joint": "revolute", "range": [-170.0, 170.0], "d": 300.0, "alpha": 90.0},
        {"joint": "revolute", "range": [-170.0, 170.0], "a": a},
        {"joint": "revolute", "range": [-170.0, 170.0], "a": 250.0},
    ]
    return {"stages": [{"kind": "serial", "convention": "dh", "links": links}]}


def _poll_ready(client: Any, robot_id: str, timeout: float = 180.0) -> dict[str, Any]:
    deadline = time.monotonic() + timeout
    while True:
        build = client.get(f"/v1/robots/{robot_id}").json()["build"]
        if build["state"] != "building" or time.monotonic() > deadline:
            return dict(build)
        time.sleep(0.05)


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_a_new_robot_answers_at_once_and_its_first_request_finds_the_structure_built(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    registry = Registry()
    document = _unique_arm()
    desc = description_from_document(document)

    # The build made slow on purpose: a 3R arm's libraries are in the disk cache after any earlier run (its lengths
    # are the Functions' inputs, not constants in them), so its real build can take 0.3 s, less than a POST
    # answered on a loaded machine (1.1 s seen), and the comparison below would say nothing.
    def slow_warm(registry: Registry, desc: RobotDescription) -> float:
        time.sleep(SLOW_BUILD_S)
        return SLOW_BUILD_S + warm_everything(registry, desc)

    monkeypatch.setattr(builds, "warm_everything", slow_warm)
    with make_client(f"sqlite:///{tmp_path}/b.db", registry, background_builds=True) as client:
        started = time.perf_counter()
        made = client.post("/v1/robots", json={"name": "arm", "structure": document})
        answered = time.perf_counter() - started
        assert made.status_code == 201, made.text
        assert made.json()["build"]["state"] == "building"
        assert made.json()["build"]["started_at"] is not None

        build = _poll_ready(client, made.json()["id"])
        assert build["state"] == "ready", build
        assert build["native"] is compiler_available()
        # The answer did not wait for the build: it took less than the build itself.
        assert build["seconds"] >= SLOW_BUILD_S > answered, (build, answered)

        runtime = registry.runtime(desc)
        before = sum(runtime.builds.values())
        assert runtime.builds["kinematics"] == 1
        fk = client.post(f"/v1/robots/{made.json()['id']}/forward-kinematics", json={"joints": [[10.0, 20.0, 30.0]]})
        assert fk.status_code == 200, fk.text
        assert sum(runtime.builds.values()) == before, "the first request built something the build had not"


def test_the_build_is_off_by_setting_and_the_robot_says_nothing_of_it(tmp_path: Path) -> None:
    registry = Registry()
    document = _unique_arm()
    with make_client(f"sqlite:///{tmp_path}/b.db", registry, background_builds=False) as client:
        made = client.post("/v1/robots", json={"name": "arm", "structure": document})
        assert made.status_code == 201
        assert made.json()["build"] is None
        assert client.get(f"/v1/robots/{made.json()['id']}").json()["build"] is None
    assert description_from_document(document) not in registry


def test_the_iwr_warmed_at_start_up_is_ready_without_a_build(tmp_path: Path, registry: Registry) -> None:
    registry.warm(iwr())  # what `build_registry` does at start-up with warm_up on
    with make_client(f"sqlite:///{tmp_path}/b.db", registry, background_builds=True) as client:
        robot_id = client.post("/v1/robots", json={"name": "cell"}).json()["id"]
        build = client.get(f"/v1/robots/{robot_id}").json()["build"]
    assert build["state"] == "ready" and build["started_at"] is None and build["seconds"] is None


@pytest.mark.slow  # a spawned process that imports the models and compiles (~5 s)
@pytest.mark.skipif(not compiler_available(), reason="no C compiler: nothing is compiled, so no cache to fill")
def test_in_its_own_process_the_build_fills_the_cache_that_a_compute_process_loads(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path / "cache"))  # inherited by the spawned build process
    desc = description_from_document(_unique_arm())
    builds = StructureBuilds(Registry(), in_process=False)
    try:
        assert builds.ensure(desc) is not None
        done = builds.wait(desc, timeout=180.0)
    finally:
        builds.shutdown()
    assert done is not None and done.state == BuildState.READY and done.native and done.seconds, done
    tag = structure_tag(desc.structure)
    assert list((tmp_path / "cache").glob(f"robot_{tag}[-.]*.so")), "the build process left no library"

    # A compute process (here: a new registry of this process) now loads instead of compiling.
    started = time.perf_counter()
    kinematics = Registry().runtime(desc).kinematics
    loaded = time.perf_counter() - started
    assert all(f.class_name() == "External" for f in kinematics.native.values())
    assert loaded < done.seconds / 2, (loaded, done.seconds)
    # and what it loaded computes what the structure's own graph does, at a random point of every input
    rng = np.random.default_rng(5)
    for name, native in kinematics.native.items():
        original = kinematics.functions[name]
        inputs = [rng.uniform(-1.0, 1.0, native.size_in(i)) for i in range(native.n_in())]
        for ours, theirs in zip(native.call(inputs), original.call(inputs), strict=True):
            assert np.allclose(ca.DM(ours).full(), ca.DM(theirs).full(), atol=1e-9), name


def test_without_native_code_the_robot_says_it_runs_on_the_virtual_machine(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("IWR_NATIVE", "0")
    desc = description_from_document(_unique_arm())
    builds = StructureBuilds(Registry(), in_process=True)
    try:
        builds.ensure(desc)
        done = builds.wait(desc, timeout=120.0)
    finally:
        builds.shutdown()
    assert done is not None and done.state == BuildState.READY
    assert done.native is False
    assert done.detail is not None and "virtual machine" in done.detail and "disabled" in done.detail


@pytest.mark.slow  # a `python -m service` started: its imports are ~2 s of CPU
def test_a_native_level_gcc_does_not_name_stops_the_service_before_it_serves() -> None:
    """A plant's `IWR_NATIVE_OPT_LEVEL=3` is refused at start-up with its name (argparse's exit 2), not by the
    first request that builds a structure. (In a process of its own: importing `service.__main__` sets the
    service's defaults in os.environ, which the apps of later tests would read.)"""
    command = [sys.executable, "-m", "service", "--port", "1"]  # refused before it would bind the port
    environment = {**os.environ, "IWR_NATIVE_OPT_LEVEL": "3"}
    started = subprocess.run(command, cwd=ROOT, env=environment, capture_output=True, text=True, check=False)
    assert started.returncode == 2, started.stderr
    assert "IWR_NATIVE_OPT_LEVEL='3': use one of 0, 1, 2" in started.stderr


@pytest.mark.slow  # two builds of a 3R arm
@pytest.mark.skipif(not compiler_available(), reason="no C compiler: nothing is compiled natively")
def test_a_structure_built_on_the_vm_then_natively_says_native(monkeypatch: pytest.MonkeyPatch) -> None:
    """The VM record is per process: a structure built once without native code (IWR_NATIVE=0, as the test above
    does) and again with it is native. Before, the first record stayed, and a later test's build in the same
    pytest worker said `native: false` whenever the order of the tests put that one first."""
    desc = description_from_document(_unique_arm())
    monkeypatch.setenv("IWR_NATIVE", "0")
    assert builds.build_structure(desc).vm, "IWR_NATIVE=0 should have put the structure on the VM"
    monkeypatch.delenv("IWR_NATIVE")
    assert builds.build_structure(desc).vm == {}
