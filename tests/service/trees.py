"""Robots of several chains through the API, for every tree test (tests/service/test_robot_trees.py,
test_robot_tree_operations.py, test_tree_report.py and tests/ui/test_trees.py): the models' example trees as the
API's documents written here, records and joint vectors in the API's units, a tree created and calibrated
through the API."""

from __future__ import annotations

from typing import Any

import numpy as np
from fastapi.testclient import TestClient
from scipy.spatial.transform import Rotation

from models.description.examples import UR5_DH
from models.noise import NoiseModel
from models.tree import RobotTree, ToolRecords
from models.tree.examples import PART, POSITIONER, TORCH, WAIST

NOISE = NoiseModel(position_mm=0.02)
ARM = {"kind": "serial", "convention": "dh", "links": [dict(row) for row in UR5_DH]}


def pose_doc(pose: tuple[float, ...] | np.ndarray) -> dict[str, list[float]]:
    """(x, y, z mm, rotation vector rad) as the API's pose: mm and a unit quaternion [w, x, y, z]."""
    x, y, z, w = Rotation.from_rotvec(np.asarray(pose[3:], dtype=float)).as_quat()
    return {"position": [float(v) for v in pose[:3]], "orientation": [float(w), float(x), float(y), float(z)]}


def torso_document(name: str = "torso") -> dict[str, Any]:
    """The models' `dual_arm_torso` as the API's document, written here; the left arm listed before the waist it
    hangs from (the service orders them)."""
    tilt = np.radians(30.0)
    return {
        "name": name,
        "branches": [
            {"name": "left", "parent": "waist", "mount": pose_doc((0, 250, 350, -tilt, 0, 0)), "stages": [ARM],
             "tool": pose_doc(TORCH)},
            {"name": "waist", "stages": [{"kind": "serial", "convention": "dh", "links": [WAIST]}]},
            {"name": "right", "parent": "waist", "mount": pose_doc((0, -250, 350, tilt, 0, 0)), "stages": [ARM],
             "tool": pose_doc(TORCH)},
        ],
    }  # fmt: skip


def positioner_document(name: str = "cell") -> dict[str, Any]:
    """The models' `arm_with_positioner` as the API's document, written here."""
    mount = (1200.0, 0.0, 600.0, np.pi / 2, 0.0, 0.0)
    return {
        "name": name,
        "branches": [
            {"name": "arm", "stages": [ARM], "tool": pose_doc(TORCH)},
            {"name": "positioner", "mount": pose_doc(mount),
             "stages": [{"kind": "serial", "convention": "dh", "links": POSITIONER}], "tool": pose_doc(PART)},
        ],
    }  # fmt: skip


def to_internal(tree: dict[str, Any]) -> np.ndarray:
    """The API's current parameters (mm, deg) as the models' vector (mm, rad), in the tree's order."""
    return np.array([p["value"] if p["unit"] == "mm" else np.radians(p["value"]) for p in tree["parameters"]])


def by_name(tree: RobotTree, q: np.ndarray) -> list[dict[str, float]]:
    """Internal joint vectors as the API's: by name, in degrees (every joint of these trees is revolute)."""
    return [dict(zip(tree.joint_names, np.degrees(row).tolist(), strict=True)) for row in q]


def record_docs(groups: list[ToolRecords], tree: RobotTree) -> list[dict[str, Any]]:
    """Records as the API's, with their orientation where measured."""
    out = []
    for g in groups:
        for k, (j, p) in enumerate(zip(by_name(tree, g.joints), g.positions, strict=True)):
            doc: dict[str, Any] = {"tool": g.tool, "frame": g.frame, "joints": j, "position": p.tolist()}
            if g.quaternions is not None:
                doc["orientation"] = g.quaternions[k].tolist()
            out.append(doc)
    return out


def create_tree(api: TestClient, body: dict[str, Any]) -> dict[str, Any]:
    """The tree `body` describes, stored through the API: its document."""
    made = api.post("/v1/robot-trees", json=body)
    assert made.status_code == 201, made.text
    found: dict[str, Any] = made.json()
    return found


def calibrate_tree(
    api: TestClient, tree_id: str, body: dict[str, Any], headers: dict[str, str] | None = None
) -> dict[str, Any]:
    """The tree calibrated through the API from `body` (records, options): the calibration's document."""
    answer = api.post(f"/v1/robot-trees/{tree_id}/calibrations", json=body, headers=headers)
    assert answer.status_code == 201, answer.text
    found: dict[str, Any] = answer.json()
    return found
