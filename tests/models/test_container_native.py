"""What a container without a compiler does (README, "The container"): libraries its build stage compiled load
and run natively; a structure first seen there runs on CasADi's VM, with a warning in the log and the
Prometheus counter `iwr_vm_only_structures_total{reason="no_compiler"}`.

Both halves run in fresh processes over one library cache: the first with the compiler (the image's build
stage), the second with the compiler scrubbed from PATH and CC (the runtime stage).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ARM = {  # a planar 2R arm in standard DH: the structure the "build stage" compiles
    "stages": [
        {
            "kind": "serial",
            "convention": "dh",
            "links": [
                {"joint": "revolute", "a": 300.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "range": [-170, 170]},
                {"joint": "revolute", "a": 200.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "range": [-170, 170]},
            ],
        }
    ]
}
NEW = {  # the same arm on a prismatic lift: a structure the container has never seen
    "stages": [
        {
            "kind": "serial",
            "convention": "dh",
            "links": [
                {"joint": "prismatic", "a": 0.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "range": [0, 500]},
                *ARM["stages"][0]["links"],
            ],
        }
    ]
}

_BUILD = """
import json, sys
from models import Registry
from models.description.structure import description_from_document
fns = Registry().runtime(description_from_document(json.loads(sys.argv[1]), name="arm")).kinematics.native
print(json.dumps(sorted({f.class_name() for f in fns.values()})))
"""

_RUN = """
import json, logging, sys
import numpy as np
from prometheus_client import generate_latest
from models import Registry, forward_kinematics
from models.engine.native import compiler_available, vm_only_structures
from models.description.structure import description_from_document
from service.metrics import Metrics

records = []
handler = logging.Handler()
handler.emit = lambda record: records.append((record.levelname, record.getMessage()))
logging.getLogger("models.engine.native").addHandler(handler)
registry = Registry()
arm = description_from_document(json.loads(sys.argv[1]), name="arm")
new = description_from_document(json.loads(sys.argv[2]), name="new")
built = {f.class_name() for f in registry.runtime(arm).kinematics.native.values()}
fresh = {f.class_name() for f in registry.runtime(new).kinematics.native.values()}
q = np.array([[120.0, np.radians(30.0), np.radians(45.0)]])
fk_new = forward_kinematics(new, q, runtime=registry.runtime(new)).positions[0]
metrics = [line for line in generate_latest(Metrics().registry).decode().splitlines() if "vm_only" in line]
print(json.dumps({
    "compiler": compiler_available(), "built": sorted(built), "fresh": sorted(fresh),
    "fk_new": fk_new.tolist(), "vm_only": {k: v.value for k, v in vm_only_structures().items()},
    "new_tag": registry.runtime(new).tag, "log": records, "metrics": metrics,
}))
"""


def _python(code: str, env: dict[str, str], *args: str) -> object:
    command = [sys.executable, "-c", code, *args]
    out = subprocess.run(command, check=False, capture_output=True, text=True, env=env, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # over a second here: outside the inner loop (make test-fast)
def test_a_container_without_a_compiler_loads_built_libraries_and_runs_new_structures_on_the_vm(
    tmp_path: Path,
) -> None:
    if shutil.which(os.environ.get("CC", "cc")) is None:
        pytest.skip("the build stage needs a compiler")
    base = {k: v for k, v in os.environ.items() if not k.startswith("IWR_") and k != "CC"}
    env = {**base, "IWR_CACHE_DIR": str(tmp_path / "cache")}
    # The build stage: the arm's library compiled into the cache.
    assert _python(_BUILD, env, json.dumps(ARM)) == ["External"]
    built = sorted((tmp_path / "cache").glob("*.so"))
    assert built and all(p.name.startswith("robot_") for p in built)
    # The runtime stage: no compiler on PATH, no CC.
    (tmp_path / "empty-bin").mkdir()
    scrubbed = {**env, "PATH": str(tmp_path / "empty-bin")}
    seen = _python(_RUN, scrubbed, json.dumps(ARM), json.dumps(NEW))
    assert isinstance(seen, dict)
    assert seen["compiler"] is False
    assert seen["built"] == ["External"]  # the build stage's library, loaded without a compiler
    assert seen["fresh"] == ["SXFunction"]  # the new structure: CasADi's VM
    # ... which computes the same kinematics: lift 120 mm, then the planar 2R arm at 30° and 45°.
    x = 300 * math.cos(math.radians(30)) + 200 * math.cos(math.radians(75))
    y = 300 * math.sin(math.radians(30)) + 200 * math.sin(math.radians(75))
    assert seen["fk_new"] == pytest.approx([x, y, 120.0], abs=1e-9)
    assert seen["vm_only"] == {seen["new_tag"]: "no_compiler"}
    warnings = [message for level, message in seen["log"] if level == "WARNING"]
    assert len(warnings) == 1 and "virtual machine" in warnings[0] and seen["new_tag"] in warnings[0]
    assert 'iwr_vm_only_structures_total{reason="no_compiler"} 1.0' in seen["metrics"]
    assert 'iwr_vm_only_structures_total{reason="compile_failed"} 0.0' in seen["metrics"]
    # Nothing was written for the new structure: the cache holds the build stage's libraries only.
    assert sorted((tmp_path / "cache").glob("*.so")) == built
