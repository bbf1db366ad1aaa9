"""Regenerate the instrument examples of a UR5-like arm whose every DH parameter is off (a simulated robot with
a known truth, so the files calibrate to a known answer): `python examples/instruments/make_examples.py`.

- `ur5_robot.json`: the robot to create (`POST /v1/robots`).
- `ballbar.csv`: three ballbar pivots × 36 records in the CSV layout of several kinds; the third bar's length
  offset is unknown (`?length_unknown=a3`), σ 2 µm (`?noise_position_mm=0.002`).
- `probe_and_sockets.json`: a calibration body with two sockets touched in ten orientations each, a plate
  probed at 30 places and one ballbar pivot for the length.
- `camera.json`: a calibration body with 30 images of a camera 1.5 m away seeing four markers on the tool
  (σ 0.1 px), its intrinsics under `cameras`.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from harness.ballbar import PIVOTS, ballbar_campaign, gauge_truth, reaching
from harness.camera import WORLD_CAMERA, world_camera_campaign
from models import forward_kinematics, sample_workspace
from models.description.examples import ur5_like, ur5_like_document

HERE = Path(__file__).parent
SEED = 2026
SIGMA_MM = 0.002


def main() -> None:
    robot = ur5_like()
    (HERE / "ur5_robot.json").write_text(
        json.dumps({"name": "ur5-cell-7", "structure": ur5_like_document()}, indent=2) + "\n"
    )
    _, groups = ballbar_campaign(robot, SEED, per_pivot=36, sigma_mm=SIGMA_MM)
    with (HERE / "ballbar.csv").open("w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["kind", "anchor", *[f"A{k + 1}" for k in range(6)], "distance_mm"])
        for group in groups:
            for q, d in zip(group.joints * robot.joint_to_boundary, group.values, strict=True):
                writer.writerow(["distance", group.reference.name, *(f"{v:.6f}" for v in q), f"{d:.5f}"])
    (HERE / "probe_and_sockets.json").write_text(json.dumps(_probe_body(), indent=1) + "\n")
    (HERE / "camera.json").write_text(json.dumps(_camera_body(), indent=1) + "\n")
    print(f"wrote the examples in {HERE}")


def _probe_body() -> dict[str, object]:
    desc = ur5_like()
    truth = gauge_truth(desc, SEED)
    rng = np.random.default_rng(SEED)
    scale = desc.joint_to_boundary
    records: list[dict[str, object]] = []
    for k, socket in enumerate(([400.0, 100.0, 200.0], [-100.0, 420.0, 150.0])):
        # The sphere sits in its socket to within the σ of the campaign: where the TCP really was.
        seated = np.tile(socket, (14, 1)) + rng.normal(0, SIGMA_MM, (14, 3))
        joints = reaching(desc, truth, seated, SEED + k)[:10]
        records += [{"kind": "point", "joints": _row(q), "point": f"socket{k + 1}"} for q in joints * scale]
    plate = np.column_stack([rng.uniform(150, 450, 40), rng.uniform(-300, 300, 40), 60.0 + rng.normal(0, SIGMA_MM, 40)])
    touches = reaching(desc, truth, plate, SEED + 10)[:30]
    records += [{"kind": "plane", "joints": _row(q), "plane": "table"} for q in touches * scale]
    bar = sample_workspace(desc, 30, seed=SEED)
    reads = np.linalg.norm(forward_kinematics(desc, bar, truth).positions - PIVOTS[0], axis=1)
    reads += rng.normal(0, SIGMA_MM, reads.size)
    records += [
        {"kind": "distance", "joints": _row(q), "anchor": "pivot", "distance_mm": round(float(d), 5)}
        for q, d in zip(bar * scale, reads, strict=True)
    ]
    return {
        "measurements": records,
        "anchors": {"pivot": {}},
        "planes": {"table": {"normal": [0, 0, 1]}},
        "noise": {"position_mm": SIGMA_MM},
        "instrument": {"name": "touch probe, sockets and a ballbar"},
    }


def _camera_body() -> dict[str, object]:
    desc = ur5_like()
    seen = world_camera_campaign(desc, SEED, images=30)
    images = [
        {
            **image,
            "joints": _row(np.asarray(image["joints"]) * desc.joint_to_boundary),
            "points": [
                {"target_mm": p["target_mm"], "pixel": [round(v, 4) for v in p["pixel"]]} for p in image["points"]
            ],
        }
        for image in seen.images
    ]
    return {"measurements": images, "cameras": WORLD_CAMERA, "instrument": {"name": "a 3-Mpx camera, 12 mm lens"}}


def _row(q: np.ndarray) -> list[float]:
    return [round(float(v), 7) for v in q]  # 1e-7 deg: 2 nm at a metre, far below the σ


if __name__ == "__main__":
    main()
