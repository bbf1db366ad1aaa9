"""A metrology engineer's session against the service (`make run` first):

    python examples/calibrate_cell.py [http://127.0.0.1:8000]

Creates the robot, asks for the 30 best poses to measure, sends a campaign measured by a laser tracker
(`campaign.csv`, here from a simulated robot), prints the calibration report, and compensates targets.
Set IWR_API_KEY if the service requires a key. Only the standard library: any Python 3.11 runs it.
"""

from __future__ import annotations

import json
import os
import sys
import time
import urllib.error
import urllib.request
import uuid
from pathlib import Path
from typing import Any

CAMPAIGN = Path(__file__).with_name("campaign.csv")


class Api:
    """JSON over HTTP with the standard library; an error answer raises with the problem's detail."""

    def __init__(self, base_url: str, headers: dict[str, str]) -> None:
        self.base_url, self.headers = base_url.rstrip("/"), headers

    def post(self, path: str, *, json_body: Any = None, text: str | None = None, content_type: str = "") -> Any:
        data = text.encode() if text is not None else json.dumps(json_body).encode()
        headers = {**self.headers, "Content-Type": content_type or "application/json", "Accept": "application/json"}
        request = urllib.request.Request(self.base_url + path, data=data, headers=headers, method="POST")
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                return json.load(response)
        except urllib.error.HTTPError as exc:
            problem = json.loads(exc.read() or b"{}")
            raise SystemExit(f"{exc.code} from {path}: {problem.get('detail', exc.reason)}") from None

    def get(self, path: str) -> Any:
        request = urllib.request.Request(self.base_url + path, headers={**self.headers, "Accept": "application/json"})
        with urllib.request.urlopen(request, timeout=30) as response:
            return json.load(response)

    def job(self, path: str, json_body: Any) -> Any:
        """Work over the service's synchronous budget (a 2 000-candidate design) runs as a job: submit, poll."""
        accepted = self.post(path + "?async=true", json_body=json_body)
        while True:
            job = self.get(accepted["status_url"])
            if job["status"] == "succeeded":
                return job["result"]
            if job["status"] == "failed":
                raise SystemExit(f"job {job['id']} failed: {job['error']['detail']}")
            time.sleep(0.5)


def main(base_url: str = "http://127.0.0.1:8000") -> None:
    headers = {"X-API-Key": os.environ["IWR_API_KEY"]} if os.environ.get("IWR_API_KEY") else {}
    api = Api(base_url, headers)
    name = f"cell-3-{uuid.uuid4().hex[:6]}"  # robot names are unique in a service
    robot = api.post("/v1/robots", json_body={"name": name, "model": "iwr"})
    rid = robot["id"]
    print(f"robot {rid} created, parameter version {robot['parameter_version']}")

    design = api.job(f"/v1/robots/{rid}/pose-designs", {"count": 30, "criterion": "I"})
    m, r = design["metrics"], design["random_baseline"]
    print(
        f"designed 30 poses: predicted TCP error after calibration {m['predicted_rms_tcp_mm']:.4f} mm "
        f"(random poses: {r['predicted_rms_tcp_mm']:.4f} mm), condition {m['condition_number']:.0f} "
        f"(random: {r['condition_number']:.0f})"
    )

    report = api.post(f"/v1/robots/{rid}/calibrations", text=CAMPAIGN.read_text(), content_type="text/csv")
    before, after = report["residuals"]["before"], report["residuals"]["after"]
    print(f"calibration {report['id']}: {report['status']}, parameter version {report['parameter_version']}")
    for label, r, digits in (("before:", before, 3), ("after: ", after, 4)):
        print(
            f"  residuals {label} {r['rms_mm']:.{digits}f} mm RMS, {r['max_mm']:.{digits}f} mm max, "
            f"{r['rms_deg']:.{digits + 1}f}° RMS"
        )
    print(f"  variance factor {report['variance_factor']:.2f} (1 = the stated noise fits)")
    acc = report["predicted_accuracy"]
    print(f"  predicted TCP accuracy: {acc['rms_position_mm']:.4f} mm RMS, {acc['max_position_mm']:.4f} mm max")
    unidentifiable = ", ".join(report["unidentifiable"])
    print(f"  {len(report['identifiable'])} identifiable parameters; unidentifiable: {unidentifiable}")
    print("  parameter                value        std error")
    for p in report["parameters"]:
        if p["identifiable"] and p["name"].startswith(("link", "tool")):
            print(f"  {p['name']:<16} {p['value']:>12.4f} {p['unit']:<3} ± {p['std_error']:.4f}")

    fk = api.post(
        f"/v1/robots/{rid}/forward-kinematics",
        json_body={
            "joints": [
                [644.0, 242.4, 92.8, 25.7, 462.7, 477.7, 449.5, 485.4, 487.0, 462.2],
                [43.1, 115.0, 73.5, 4.1, 425.2, 466.4, 446.4, 470.7, 464.2, 447.2],
            ]
        },
    )
    targets = [{"position": [v + 1.0 for v in p["position"]], "orientation": p["orientation"]} for p in fk["poses"]]
    answer = api.post(f"/v1/robots/{rid}/inverse-kinematics", json_body={"targets": targets})
    for k, joints in enumerate(answer["joints"]):
        state = "reachable" if answer["reachable"][k] else answer["reasons"][k]
        shown = ", ".join(f"{v:.3f}" for v in joints)
        print(f"target {k}: [{shown}] ({state}, model error {answer['position_error_mm'][k]:.1e} mm)")


if __name__ == "__main__":
    main(*sys.argv[1:])
