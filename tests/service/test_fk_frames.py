"""Every frame of a pose through POST …/forward-kinematics (`frames: true`), what the browser draws a robot's
links from: each frame against the textbook DH product of tests/models/cell_reference.py, the TCP against the
response's own pose, a hexapod's legs placed by their joints' points as long as the legs' joint values, and the
request bounded with a 422 naming `frames`."""

from __future__ import annotations

import numpy as np
import pytest
from fastapi.testclient import TestClient

from models.description.examples import hexapod_alone_document
from models.description.structure import description_from_document
from models.transforms import quaternion_to_matrix
from service.schemas.kinematics import FRAMES_MAX
from tests.models.cell_reference import dh_frames
from tests.service.helpers import posted_ur5

JOINTS_DEG = [[0, -90, 80, -90, 90, 0], [30, -60, 45, -120, -45, 10], [-100, -120, 100, 0, 60, 170]]


@pytest.fixture
def ur5(client: TestClient) -> str:
    return posted_ur5(client, "ur5-frames")


@pytest.mark.slow  # > 0.25 s of CPU: make test runs it, test-fast does not
def test_every_frame_is_the_textbook_dh_product(client: TestClient, ur5: str) -> None:
    answer = client.post(f"/v1/robots/{ur5}/forward-kinematics", json={"joints": JOINTS_DEG, "frames": True})
    assert answer.status_code == 200, answer.text
    found = answer.json()
    names = client.put(f"/v1/robots/{ur5}/cell", json={}).json()["frames"]  # the names the cell's shapes use
    desc = description_from_document(client.get(f"/v1/robots/{ur5}/structure").json())
    truth = dh_frames(desc, np.radians(np.asarray(JOINTS_DEG, dtype=float)))
    assert len(found["frames"]) == len(JOINTS_DEG)
    for k, frames in enumerate(found["frames"]):
        assert list(frames) == names == ["base", *[f"link{i}{m}" for i in range(1, 7) for m in (".mid", "")], "tcp"]
        for f, name in enumerate(names):
            assert np.allclose(frames[name]["position"], truth[k, f, :3, 3], atol=1e-9)
            rotation = quaternion_to_matrix(np.asarray(frames[name]["orientation"])[None])[0]
            assert np.allclose(rotation, truth[k, f, :3, :3], atol=1e-12)
        assert frames["tcp"]["position"] == pytest.approx(found["poses"][k]["position"], abs=1e-9)


def test_frames_are_absent_unless_asked_and_bounded(client: TestClient, ur5: str) -> None:
    url = f"/v1/robots/{ur5}/forward-kinematics"
    plain = client.post(url, json={"joints": JOINTS_DEG[:1]}).json()
    assert "frames" not in plain
    many = client.post(url, json={"joints": JOINTS_DEG[:1] * (FRAMES_MAX + 1), "frames": True})
    assert many.status_code == 422 and "frames" in many.text and str(FRAMES_MAX) in many.text


def test_a_hexapods_legs_run_between_its_joints(client: TestClient) -> None:
    """A leg's capsule runs from its base joint (a point of the base frame) to its platform joint (a point of
    the platform's frame): placed on the answered frames, each is as long as the leg's joint value says, the
    closure the service solved (an independent check: nothing here solves it)."""
    made = client.post("/v1/robots", json={"name": "hexapod-frames", "structure": hexapod_alone_document()})
    robot_id = made.json()["id"]
    legs = [[300, 310, 320, 330, 340, 350], [350, 340, 330, 320, 310, 300]]
    shapes = client.put(f"/v1/robots/{robot_id}/cell", json={}).json()["geometry"]
    found = client.post(f"/v1/robots/{robot_id}/forward-kinematics", json={"joints": legs, "frames": True}).json()
    for q, frames in zip(legs, found["frames"], strict=True):
        lengths = []
        for shape in shapes[:6]:
            ends = []
            for frame, point in ((shape["from_frame"], "from_point_mm"), (shape["to_frame"], "to_point_mm")):
                rotation = quaternion_to_matrix(np.asarray(frames[frame]["orientation"])[None])[0]
                ends.append(np.asarray(frames[frame]["position"]) + rotation @ np.asarray(shape[point]))
            lengths.append(float(np.linalg.norm(ends[1] - ends[0])))
        assert lengths == pytest.approx(q, abs=1e-6)
    assert [s["body"] for s in shapes] == ["stage1"] * 6 + ["tool"]
