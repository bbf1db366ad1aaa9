"""Everything is built once per robot structure, whatever the nominal values, and owned by a runtime."""

from __future__ import annotations

import os
import shutil
import threading
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from models import Registry, RobotDescription, default_registry, forward_kinematics, iwr, sample_workspace
from models.compensation import inverse_kinematics
from models.description.serial_chain import DHLink, JointType
from models.engine import native
from models.engine.native import compile_functions
from models.identification import identify
from models.simulation import measure, perturbed_robot
from models.stages import SerialStage
from models.transforms import matrix_to_quaternion
from models.warm import warm_everything


def test_one_build_per_structure() -> None:
    first = default_registry().runtime(iwr())
    kinematics = first.kinematics
    builds = first.builds["kinematics"]
    other_base = iwr(base=(1000.0, 0.0, 0.0, 0.0, 0.0, 0.3), tool=(0.0, 0.0, 150.0, 0.0, 0.0, 0.0))
    assert default_registry().runtime(other_base) is first
    assert first.kinematics is kinematics
    joints = sample_workspace(other_base, 20, seed=1)
    forward_kinematics(other_base, joints, jacobian=True)
    forward_kinematics(iwr(), joints)
    assert first.builds["kinematics"] == builds == 1


def test_base_and_tool_are_inputs_not_graph_constants() -> None:
    plain, moved = iwr(), iwr(base=(0.0, 0.0, 100.0, 0.0, 0.0, 0.0))
    joints = sample_workspace(plain, 4, seed=2)
    a = forward_kinematics(plain, joints).positions
    b = forward_kinematics(moved, joints, moved.parameters.nominal).positions
    np.testing.assert_allclose(b - a, np.tile([0.0, 0.0, 100.0], (4, 1)), atol=1e-9)


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_every_artefact_is_built_once_through_an_injected_registry(desc: RobotDescription) -> None:
    registry = Registry()
    runtime = registry.runtime(desc)
    assert runtime.builds == {}
    seconds = warm_everything(registry, desc)
    assert seconds > 0
    warm = runtime.builds
    for artefact in ("kinematics", "kkt", "ik_nlp", "start_table", "structural_subset", "ipopt_pool"):
        assert warm[artefact] >= 1, artefact
    assert warm["kinematics"] == warm["kkt"] == warm["ik_nlp"] == warm["ipopt_pool"] == 1
    assert warm["ipopt_solver"] == 2  # one per measurement kind's identifiable count

    # Requests on robots of this structure (other bases, other campaign sizes) build nothing more,
    # except the start table of a new calibrated parameter vector.
    sim = perturbed_robot(desc, seed=21)
    for n in (30, 41):
        result = identify(desc, measure(sim, sample_workspace(desc, n, seed=n), seed=n), runtime=runtime)
        assert result.succeeded
    fk = forward_kinematics(desc, sample_workspace(desc, 3, seed=5), result.parameters, runtime=runtime)
    inverse_kinematics(desc, fk.positions, matrix_to_quaternion(fk.rotations), result.parameters, runtime=runtime)
    after = runtime.builds
    assert after.pop("start_table") == warm.pop("start_table") + 1
    assert after == warm
    assert warm_everything(registry, desc) < seconds  # already warm
    assert default_registry().runtime(desc) is not runtime  # injected, not shared


def _with_links(desc: RobotDescription, links: tuple[DHLink, ...]) -> RobotDescription:
    """The IWR with other carriage links (its first stage), the hexapod kept."""
    return replace(desc, stages=(SerialStage(links), *desc.stages[1:]))


def test_registry_evicts_the_least_recently_used_structure(desc: RobotDescription) -> None:
    registry = Registry(capacity=2)
    revolute = _with_links(desc, (*desc.links[:-1], replace(desc.links[-1], joint=JointType.REVOLUTE)))
    prismatic = _with_links(desc, (*desc.links[:-1], replace(desc.links[-1], joint=JointType.PRISMATIC)))
    assert len({desc.structure, revolute.structure, prismatic.structure}) == 2  # the IWR's last joint is one of them
    other = revolute if revolute.structure != desc.structure else prismatic
    shorter = _with_links(desc, desc.links[:-1])
    a, b = registry.runtime(desc), registry.runtime(other)
    assert registry.runtime(desc) is a  # now most recent
    c = registry.runtime(shorter)
    assert len(registry) == 2 and desc in registry and shorter in registry and other not in registry
    assert registry.runtime(desc) is a and registry.runtime(shorter) is c
    assert registry.runtime(other) is not b and registry.created == 4


def test_concurrent_first_use_builds_once(desc: RobotDescription) -> None:
    runtime = Registry().runtime(desc)
    calls = []

    def build() -> int:
        calls.append(1)
        threading.Event().wait(0.05)
        return 42

    threads = [threading.Thread(target=lambda: runtime.artefact("probe", "k", build)) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(calls) == 1 and runtime.builds["probe"] == 1


def test_a_runtime_refuses_another_structure(desc: RobotDescription) -> None:
    runtime = Registry().runtime(desc)
    shorter = _with_links(desc, desc.links[:-1])
    with pytest.raises(ValueError, match="structure"):
        forward_kinematics(shorter, np.zeros(shorter.n_joints), runtime=runtime)


def test_a_built_library_loads_without_a_compiler(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("needs a compiler once, to build the library")
    x = ca.SX.sym("x", 2)
    f = ca.Function("probe_square", [x], [x * x])
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path))
    built = compile_functions("probe", [f])
    assert isinstance(built["probe_square"], ca.Function) and list(tmp_path.glob("probe-*.so"))
    # No compiler on PATH (an empty PATH and a compiler name that does not exist): the library is loaded.
    monkeypatch.setenv("PATH", str(tmp_path / "no-bin"))
    monkeypatch.setenv("CC", "no-such-cc")
    loaded = compile_functions("probe", [f])["probe_square"]
    assert loaded.class_name() == "External"
    np.testing.assert_allclose(np.asarray(loaded([3.0, 4.0])).ravel(), [9.0, 16.0])
    # And with neither a library nor a compiler, the CasADi VM's Function comes back.
    fallback = compile_functions("other", [f])["probe_square"]
    assert fallback.class_name() == "SXFunction"


def test_each_optimization_level_is_a_library_of_its_own_with_the_same_numbers(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`IWR_NATIVE_OPT_LEVEL` is gcc's -O and part of the hash: the suite's -O0 libraries and the service's -O1
    ones live side by side in one cache, never one loaded for the other, and compute the same bits; a level gcc's
    flags do not name is refused with the setting's name."""
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("needs a compiler")
    x = ca.SX.sym("x", 3)
    f = ca.Function("probe_mix", [x], [ca.sin(x) * x[0] + ca.sqrt(1 + x * x) / 3])
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path))
    point = [0.3, -1.7, 2.9]
    values = {}
    for level in ("0", "1"):
        monkeypatch.setenv("IWR_NATIVE_OPT_LEVEL", level)
        assert native.compile_flags()[0] == f"-O{level}"
        values[level] = np.asarray(compile_functions("levels", [f])["probe_mix"](point)).ravel()
    assert len(list(tmp_path.glob("levels-*.so"))) == 2
    np.testing.assert_array_equal(values["0"], values["1"])
    np.testing.assert_allclose(values["1"], np.asarray(f(point)).ravel(), rtol=1e-15)
    monkeypatch.delenv("IWR_NATIVE_OPT_LEVEL")
    assert native.optimization_flag() == "-O1"  # the service's default
    monkeypatch.setenv("IWR_NATIVE_OPT_LEVEL", "3")
    with pytest.raises(ValueError, match="IWR_NATIVE_OPT_LEVEL='3'"):
        compile_functions("levels", [f])


@pytest.mark.slow  # over 0.25 s: outside the inner loop (make test-fast)
def test_concurrent_builders_of_one_library_compile_it_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Two test workers (or job workers) meeting a new structure on a cold cache: one compiles, the other waits
    for the lock and loads what it built. The compiler is a wrapper that counts its runs."""
    real = shutil.which(os.environ.get("CC", "cc"))
    if real is None:
        pytest.skip("needs a compiler")
    runs = tmp_path / "runs"
    wrapper = tmp_path / "counting-cc"
    wrapper.write_text(f'#!/bin/sh\necho run >> "{runs}"\nsleep 0.5\nexec "{real}" "$@"\n')
    wrapper.chmod(0o755)
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", str(wrapper))
    x = ca.SX.sym("x", 3)
    f = ca.Function("probe_cube", [x], [x * x * x])
    results: list[ca.Function] = []
    threads = [
        threading.Thread(target=lambda: results.append(compile_functions("cold", [f])["probe_cube"])) for _ in range(3)
    ]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert runs.read_text().count("run") == 1
    assert [r.class_name() for r in results] == ["External"] * 3
    for loaded in results:
        np.testing.assert_allclose(np.asarray(loaded([1.0, 2.0, 3.0])).ravel(), [1.0, 8.0, 27.0])


@pytest.mark.slow  # two compilers of 0.5 s each: outside the inner loop (make test-fast)
def test_a_library_of_several_functions_compiles_its_parts_at_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The Functions are dealt to `PARTS` libraries by size, their compilers run side by side (the wrapper logs
    each run's start and end), and every Function computes what CasADi's VM computes."""
    real = shutil.which(os.environ.get("CC", "cc"))
    if real is None:
        pytest.skip("needs a compiler")
    log = tmp_path / "runs"
    wrapper = tmp_path / "logging-cc"
    wrapper.write_text(
        f'#!/bin/sh\necho "start $(date +%s.%N)" >> "{log}"\nsleep 0.5\n"{real}" "$@"\nrc=$?\n'
        f'echo "end $(date +%s.%N)" >> "{log}"\nexit $rc\n'
    )
    wrapper.chmod(0o755)
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("CC", str(wrapper))
    x = ca.SX.sym("x", 3)
    functions = [
        ca.Function("big", [x], [ca.sin(x) * ca.cos(x) + x**3 - ca.exp(-x) * x]),
        ca.Function("small", [x], [2 * x]),
        ca.Function("middle", [x], [ca.sin(x) + x * x]),
    ]
    built = compile_functions("split", functions)
    libraries = sorted((tmp_path / "cache").glob("*.so"))
    assert [p.name.split("-")[0] for p in libraries] == [f"split.{i}" for i in range(native.PARTS)]
    # The largest Function alone in one library, the two others in the other.
    assert {built[name].class_name() for name in ("big", "small", "middle")} == {"External"}
    events = [line.split() for line in log.read_text().splitlines()]
    starts = sorted(float(t) for kind, t in events if kind == "start")
    ends = sorted(float(t) for kind, t in events if kind == "end")
    assert len(starts) == native.PARTS and starts[-1] < ends[0], "the compilers ran one after the other"
    point = [0.3, -1.2, 2.0]
    for f in functions:
        np.testing.assert_allclose(np.asarray(built[f.name()](point)).ravel(), np.asarray(f(point)).ravel())
    # A failing compiler sends every Function of the library to the VM, and leaves no part behind.
    monkeypatch.setenv("IWR_CACHE_DIR", str(tmp_path / "cache2"))
    monkeypatch.setenv("CC", "false")
    fallback = compile_functions("split", functions)
    assert {f.class_name() for f in fallback.values()} == {"SXFunction"}
    assert not list((tmp_path / "cache2").glob("*.so"))


def test_a_runtime_without_a_compiler_uses_the_built_robot_library(
    desc: RobotDescription, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    if os.environ.get("IWR_NATIVE") == "0" or shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("needs native compilation enabled and a compiler once")
    assert all(f.class_name() == "External" for f in default_registry().runtime(desc).kinematics.native.values())
    monkeypatch.setenv("PATH", str(tmp_path / "no-bin"))
    monkeypatch.setenv("CC", "no-such-cc")
    fresh = Registry().runtime(desc).kinematics  # a new build, as in a runtime image without a compiler
    assert all(f.class_name() == "External" for f in fresh.native.values())
