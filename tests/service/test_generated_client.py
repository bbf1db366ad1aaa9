"""A client generated from nothing but the committed service/openapi.json runs the example session.

openapi-python-client (a dev dependency, offline once installed) writes a typed Python package from the
contract into a temporary directory; the test imports it and runs the flow of examples/calibrate_cell.py
(create a robot, calibrate the shipped campaign, read the parameters, forward kinematics) against a live
server, then makes the same calls directly and compares the numbers.

The operations are found by their operationId (looked up by method and path in openapi.json), and the
request bodies are built with the generated classes found from each function's `body` annotation. The
responses are compared as the JSON the server sent: the contract's response schemas are still loose
(issue 10 types them), so nothing here depends on today's generated response classes.
"""

from __future__ import annotations

import csv
import importlib
import json
import re
import subprocess
import sys
import types
import typing
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import httpx
import numpy as np
import pytest

from harness.live import ROOT

pytestmark = pytest.mark.slow

CONTRACT = ROOT / "service" / "openapi.json"
CAMPAIGN = ROOT / "examples" / "campaign.csv"
PACKAGE = "iwr_generated_client"
# The two poses of examples/calibrate_cell.py.
JOINTS = [
    [644.0, 242.4, 92.8, 25.7, 462.7, 477.7, 449.5, 485.4, 487.0, 462.2],
    [43.1, 115.0, 73.5, 4.1, 425.2, 466.4, 446.4, 470.7, 464.2, 447.2],
]


SHADOWED = '        d = d.pop("d", UNSET)\n'


def _repair_shadowed_d(package: Path) -> None:
    """The one defect of the locked generator that the contract meets: its `from_dict` names its working copy
    of the input `d`, so a property named `d` (robots.md's link offset, `StructureLink.d`) overwrites it and
    every later `d.pop` fails. Only that local is renamed, nothing of the contract; the assertion fails when
    the generator stops writing it, so the repair goes with the defect."""
    repaired = 0
    for module in sorted((package / "models").glob("*.py")):
        text = module.read_text()
        if SHADOWED in text:
            text = text.replace(SHADOWED, SHADOWED.replace("d = ", "d_ = ")).replace(
                "\n            d=d,\n", "\n            d=d_,\n"
            )
            module.write_text(text)
            repaired += 1
    assert repaired == 1, f"the generator's from_dict no longer shadows `d` in {repaired} != 1 model: drop this repair"


@pytest.fixture(scope="module")
def generated(tmp_path_factory: pytest.TempPathFactory) -> Iterator[ModuleType]:
    out = tmp_path_factory.mktemp("client")
    config = out / "config.yaml"
    # No post hooks: the generated code is imported, not committed, so it need not be formatted.
    config.write_text(f"post_hooks: []\npackage_name_override: {PACKAGE}\n")
    generator = Path(sys.executable).parent / "openapi-python-client"
    command = [str(generator), "generate", "--path", str(CONTRACT), "--meta", "none", "--config", str(config)]
    done = subprocess.run(
        [*command, "--output-path", str(out / PACKAGE)],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    _repair_shadowed_d(out / PACKAGE)
    sys.path.insert(0, str(out))
    try:
        yield importlib.import_module(PACKAGE)
    finally:
        sys.path.remove(str(out))
        for name in [m for m in sys.modules if m == PACKAGE or m.startswith(PACKAGE + ".")]:
            del sys.modules[name]


def _operation(client_package: ModuleType, method: str, path: str) -> ModuleType:
    """The generated module of the operation at `method path`, found by its operationId."""
    operation_id = json.loads(CONTRACT.read_text())["paths"][path][method]["operationId"]
    name = re.sub(r"[^a-z0-9]+", "_", operation_id.lower()).strip("_")
    assert client_package.__file__ is not None  # a package, imported from its folder
    found = sorted((Path(client_package.__file__).parent / "api").glob(f"*/{name}.py"))
    assert len(found) == 1, f"no single generated module for {operation_id}: {found}"
    return importlib.import_module(f"{PACKAGE}.api.{found[0].parent.name}.{name}")


def _call(client_package: ModuleType, client: Any, method: str, path: str, body: Any = None, **params: Any) -> Any:
    """Calls the operation through the generated function, the body typed by its generated class."""
    sync_detailed: Callable[..., Any] = _operation(client_package, method, path).sync_detailed
    kwargs = dict(params)
    if body is not None:
        body_type = typing.get_type_hints(sync_detailed)["body"]
        if isinstance(body_type, types.UnionType):
            # An operation that takes several media types (the calibration: JSON or multipart files) gets a union;
            # the JSON schema's class is the one named by its component, not the generated "...Body".
            body_type = next(t for t in body_type.__args__ if not t.__name__.endswith("Body"))
        kwargs["body"] = body_type.from_dict(body)
    response = sync_detailed(client=client, **kwargs)
    assert 200 <= response.status_code < 300, response.content
    return json.loads(response.content)


def _campaign_as_json() -> dict[str, Any]:
    """examples/campaign.csv as the JSON body the contract declares (the CSV body is not in the contract)."""
    with CAMPAIGN.open() as f:
        rows = list(csv.DictReader(f))
    joints = ["q1", "q2", "q3", "q4", "l1", "l2", "l3", "l4", "l5", "l6"]
    return {
        "measurements": [
            {
                "joints": [float(r[k]) for k in joints],
                "position": [float(r[k]) for k in ("x", "y", "z")],
                "orientation": [float(r[k]) for k in ("qw", "qx", "qy", "qz")],
            }
            for r in rows
        ]
    }


def test_generated_client_runs_the_example_session(generated: ModuleType, story_url: str) -> None:
    with (
        httpx.Client(base_url=story_url, timeout=120) as direct,
        generated.Client(base_url=story_url, timeout=httpx.Timeout(120.0)) as client,
    ):
        robot = _call(generated, client, "post", "/v1/robots", {"name": "cell-3-generated", "model": "iwr"})
        rid = robot["id"]
        report = _call(
            generated, client, "post", "/v1/robots/{robot_id}/calibrations", _campaign_as_json(), robot_id=rid
        )
        parameters = _call(generated, client, "get", "/v1/robots/{robot_id}/parameters", robot_id=rid)
        fk = _call(
            generated, client, "post", "/v1/robots/{robot_id}/forward-kinematics", {"joints": JOINTS}, robot_id=rid
        )

        # The same session made directly, the calibration with the example's own CSV body.
        other = (
            direct.post("/v1/robots", json={"name": "cell-3-direct", "model": "iwr"}).raise_for_status().json()["id"]
        )
        direct_report = (
            direct.post(
                f"/v1/robots/{other}/calibrations",
                content=CAMPAIGN.read_text(),
                headers={"Content-Type": "text/csv"},
            )
            .raise_for_status()
            .json()
        )
        direct_parameters = direct.get(f"/v1/robots/{other}/parameters").raise_for_status().json()
        direct_fk = (
            direct.post(f"/v1/robots/{other}/forward-kinematics", json={"joints": JOINTS}).raise_for_status().json()
        )

    assert report["status"] == direct_report["status"] == "succeeded"
    assert report["parameter_version"] == direct_report["parameter_version"] == 2
    for key in ("rms_mm", "max_mm", "rms_deg"):
        assert report["residuals"]["after"][key] == pytest.approx(direct_report["residuals"]["after"][key], rel=1e-9)
    assert report["residuals"]["after"]["rms_mm"] < 0.05 < report["residuals"]["before"]["rms_mm"]
    assert sorted(report["identifiable"]) == sorted(direct_report["identifiable"])

    def values(tree: Any) -> np.ndarray:
        return np.array([p["value"] for p in tree["parameters"]])

    assert [p["name"] for p in parameters["parameters"]] == [p["name"] for p in direct_parameters["parameters"]]
    np.testing.assert_allclose(values(parameters), values(direct_parameters), rtol=1e-9, atol=1e-9)
    # The calibrated parameters are what the forward kinematics then uses: both robots agree to round-off.
    assert len(fk["poses"]) == len(JOINTS)
    for ours, theirs in zip(fk["poses"], direct_fk["poses"], strict=True):
        np.testing.assert_allclose(ours["position"], theirs["position"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(ours["orientation"], theirs["orientation"], rtol=0, atol=1e-12)
