"""The client's own distribution (clients/python/pyproject.toml): built offline with the project venv's build
backend from a copy of the checkout's layout (the package stays in the top-level iwr_client/), installed into a
fresh venv with nothing else, where `iwr --help` runs and iwr_client imports with none of the project's
packages or dependencies beside it."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from harness.live import ROOT

pytestmark = pytest.mark.slow  # a wheel built and a venv made: 6-10 s here


def _run(*args: str | Path, cwd: Path) -> subprocess.CompletedProcess[str]:
    # Without the caller's PYTHONPATH: the fresh venv must find iwr_client in its own site-packages.
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    return subprocess.run(
        [str(a) for a in args], check=False, cwd=cwd, env=env, capture_output=True, text=True, timeout=180
    )


def test_the_client_installs_alone_into_a_fresh_venv(tmp_path: Path) -> None:
    # pip-compile leaves setuptools out of the lock; the venv `make install` makes has it (ensurepip's).
    pytest.importorskip("setuptools", reason="the client's build backend (setuptools) is not in this venv")
    # The checkout's layout, copied: an in-tree build would leave build/ and *.egg-info in the repository.
    source = tmp_path / "checkout"
    shutil.copytree(ROOT / "clients" / "python", source / "clients" / "python")
    shutil.copytree(ROOT / "iwr_client", source / "iwr_client", ignore=shutil.ignore_patterns("__pycache__"))
    dist = tmp_path / "dist"
    built = _run(sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-index", "--no-build-isolation",
                 "-w", dist, source / "clients" / "python", cwd=tmp_path)  # fmt: skip
    assert built.returncode == 0, built.stderr
    (wheel,) = dist.glob("iwr_client-*.whl")
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        metadata = archive.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
        scripts = archive.read(next(n for n in names if n.endswith(".dist-info/entry_points.txt"))).decode()
    assert "Requires-Dist" not in metadata  # no dependency at all
    assert "iwr = iwr_client.cli:main" in scripts
    packaged = {n for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert packaged == {f"iwr_client/{p.name}" for p in (ROOT / "iwr_client").glob("*.py")}

    venv = tmp_path / "venv"
    made = _run(sys.executable, "-m", "venv", "--without-pip", venv, cwd=tmp_path)
    assert made.returncode == 0, made.stderr
    python = venv / "bin" / "python"
    installed = _run(sys.executable, "-m", "pip", "--python", python, "install", "-q", "--no-index", "--no-deps",
                     wheel, cwd=tmp_path)  # fmt: skip
    assert installed.returncode == 0, installed.stderr
    helped = _run(venv / "bin" / "iwr", "--help", cwd=tmp_path)
    assert helped.returncode == 0, helped.stderr
    assert "calibrate" in helped.stdout and "--url" in helped.stdout
    # -I: neither the current directory nor PYTHONPATH; what imports comes from the venv alone.
    probe = "import importlib.util as u, iwr_client; print(iwr_client.__file__); "
    probe += "print([m for m in ('models', 'service', 'numpy', 'casadi') if u.find_spec(m)])"
    imported = _run(python, "-I", "-c", probe, cwd=tmp_path)
    assert imported.returncode == 0, imported.stderr
    where, others = imported.stdout.splitlines()
    assert Path(where).is_relative_to(venv) and others == "[]"
