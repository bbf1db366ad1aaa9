"""Simulated camera campaigns (a known truth for the tests and the benchmark of `identify_references` with image
records): a camera 1.5 m from a UR5-like arm seeing four markers on its tool, or a camera on the tool seeing a
board in the cell, the pixels from an independent numpy projection with noise σ.

The records go through the contract's reader (`read_images`), as a user's would."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from harness.ballbar import gauge_truth
from models import RobotDescription, forward_kinematics, sample_workspace
from models.measurements.camera import read_images
from models.measurements.references import ReferenceRecords

INTRINSICS: dict[str, Any] = {
    "fx": 2000.0,
    "fy": 1995.0,
    "cx": 1024.0,
    "cy": 768.0,
    "distortion": [-0.12, 0.03, 2e-4, -1.5e-4, 0.0],
}
"""A 3-Mpx industrial camera with a 12 mm lens (fx ≈ 2000 px), its distortion as a prior calibration gave it."""
WORLD_CAMERA_POSITION = np.array([1500.0, 0.0, 200.0])
WORLD_CAMERA_ROTATION = np.column_stack([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
"""Looking back at the robot along −x (its z axis), image v down (−z): columns x_c, y_c, z_c in the world."""
MARKERS = np.array([[60.0, 0.0, 10.0], [0.0, 60.0, -10.0], [-60.0, 0.0, 30.0], [0.0, -60.0, 0.0]])
"""Four markers on the tool (its frame, mm), not on one plane."""
HAND_EYE_POSITION = np.array([40.0, -30.0, 20.0])
HAND_EYE_ROTATION = np.eye(3)
"""A camera beside the TCP, looking along the tool's z axis."""


@dataclass(frozen=True)
class CameraCampaign:
    truth: np.ndarray
    """The robot's true parameters (its base the nominal one where the camera fixes no frame)."""
    rotation: np.ndarray
    position: np.ndarray
    """The camera's true pose in its parent frame (world or tool)."""
    groups: tuple[ReferenceRecords, ...]
    images: list[dict[str, Any]]
    """The records as the contract gives them."""


def project(points_cam: np.ndarray, intrinsics: dict[str, Any]) -> np.ndarray:
    """OpenCV's pinhole projection with Brown–Conrady distortion, written out once more in numpy (the model's
    is `Intrinsics.project`)."""
    k1, k2, p1, p2, k3 = intrinsics.get("distortion", [0.0] * 5)
    a, b = points_cam[:, 0] / points_cam[:, 2], points_cam[:, 1] / points_cam[:, 2]
    r2 = a * a + b * b
    radial = 1 + k1 * r2 + k2 * r2**2 + k3 * r2**3
    xd = a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a)
    yd = b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b
    return np.column_stack([intrinsics["fx"] * xd + intrinsics["cx"], intrinsics["fy"] * yd + intrinsics["cy"]])


def _visible(cam: np.ndarray, pixels: np.ndarray, intrinsics: dict[str, Any]) -> np.ndarray:
    width, height = 2 * intrinsics["cx"], 2 * intrinsics["cy"]
    u, v = pixels[..., 0], pixels[..., 1]
    return np.asarray((cam[..., 2] > 100) & (u > 0) & (u < width) & (v > 0) & (v < height))


CAMERA_GAUGE = ("link1.theta", "link1.d")
"""What a world camera's pose absorbs besides the base: turning every link about the first axis, or lifting them
along it, is turning or lifting the camera the other way (exactly, as for a ballbar's pivots)."""


def camera_gauge_truth(desc: RobotDescription, seed: int) -> np.ndarray:
    """A perturbed robot in the gauge a world camera leaves free (its base and `CAMERA_GAUGE` nominal), so that
    the fitted camera pose and TCP can be compared with the truth without an alignment."""
    truth = gauge_truth(desc, seed)
    for name in CAMERA_GAUGE:
        truth[desc.parameters.index[name]] = desc.parameters.nominal[desc.parameters.index[name]]
    return truth


def world_images(
    desc: RobotDescription, truth: np.ndarray, joints: np.ndarray, rng: np.random.Generator, *, sigma_px: float = 0.1
) -> tuple[list[dict[str, Any]], np.ndarray]:
    """(the records, (N, 4) which markers are seen): what the fixed camera sees of the four markers at each of
    `joints` (only the markers in front of it and on its image), pixels with noise σ."""
    fk = forward_kinematics(desc, joints, truth)
    world = np.einsum("nij,mj->nmi", fk.rotations, MARKERS) + fk.positions[:, None, :]
    cam = (world - WORLD_CAMERA_POSITION) @ WORLD_CAMERA_ROTATION
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = project(cam.reshape(-1, 3), INTRINSICS).reshape(len(joints), len(MARKERS), 2)
    visible = _visible(cam, pixels, INTRINSICS)
    records = []
    for i in np.flatnonzero(visible.any(axis=1)):
        seen = np.flatnonzero(visible[i])
        noisy = pixels[i, seen] + rng.normal(0, sigma_px, (seen.size, 2))
        points = [{"target_mm": MARKERS[j].tolist(), "pixel": px.tolist()} for j, px in zip(seen, noisy, strict=True)]
        records.append({"kind": "image", "joints": joints[i].tolist(), "camera": "c1", "points": points})
        records[-1]["sigma_px"] = sigma_px
    return records, visible


WORLD_CAMERA = {"c1": {**INTRINSICS, "mount": "world"}}


def world_camera_campaign(
    desc: RobotDescription, seed: int, *, images: int = 40, sigma_px: float = 0.1, pool: int = 600
) -> CameraCampaign:
    """`images` random poses (of `pool` sampled) at which the fixed camera sees all four markers."""
    rng = np.random.default_rng(seed)
    truth = camera_gauge_truth(desc, seed)
    joints = sample_workspace(desc, pool, seed=300 + seed)
    _, visible = world_images(desc, truth, joints, rng, sigma_px=sigma_px)
    chosen = np.flatnonzero(visible.all(axis=1))[:images]
    assert chosen.size == images, f"only {chosen.size} of {pool} poses show every marker"
    records, _ = world_images(desc, truth, joints[chosen], rng, sigma_px=sigma_px)
    groups = read_images(WORLD_CAMERA, records)
    return CameraCampaign(truth, WORLD_CAMERA_ROTATION, WORLD_CAMERA_POSITION, groups, records)


HAND_EYE_GAUGE = ("link6.theta", "link6.d", "link6.a", "link6.alpha", "tool")
"""What a camera on the tool cannot tell from its own pose in the tool frame: the constant transform after the
last joint (the last link's constants and the tool's) reaches the pixels only through its product with the
hand-eye."""


def board(rows: int = 7, spacing_mm: float = 120.0, height_mm: float = -150.0) -> np.ndarray:
    """A flat grid of points in the cell (world frame), centred under the robot's reach."""
    k = (np.arange(rows) - (rows - 1) / 2) * spacing_mm
    gx, gy = np.meshgrid(k + 350.0, k)
    return np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, height_mm)])


def tool_camera_campaign(
    desc: RobotDescription, seed: int, *, images: int = 40, sigma_px: float = 0.1, pool: int = 4000
) -> CameraCampaign:
    """`images` random poses at which a camera on the tool sees at least eight points of the board. The board
    is the world frame's, so the truth's base is off its nominal too (these records see it), by what placing a
    robot by hand leaves: millimetres and milliradians. The truth is in the gauge a hand-eye camera leaves free
    (`HAND_EYE_GAUGE` nominal), so that the fitted hand-eye can be compared with the true one."""
    rng = np.random.default_rng(seed)
    truth = gauge_truth(desc, seed)
    held = list(desc.parameters.indices(HAND_EYE_GAUGE))
    truth[held] = desc.parameters.nominal[held]
    truth[desc.slices["base"]] += np.r_[rng.normal(0, 3.0, 3), rng.normal(0, 3e-3, 3)]
    points = board()
    joints = sample_workspace(desc, pool, seed=700 + seed)
    fk = forward_kinematics(desc, joints, truth)
    rot_w = fk.rotations @ HAND_EYE_ROTATION
    pos_w = fk.positions + np.einsum("nij,j->ni", fk.rotations, HAND_EYE_POSITION)
    cam = np.einsum("nji,nmj->nmi", rot_w, points[None, :, :] - pos_w[:, None, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = project(cam.reshape(-1, 3), INTRINSICS).reshape(pool, len(points), 2)
    visible = _visible(cam, pixels, INTRINSICS)
    chosen = np.flatnonzero(visible.sum(axis=1) >= 8)[:images]
    assert chosen.size == images, f"only {chosen.size} of {pool} poses see the board"
    records = []
    for i in chosen:
        seen = np.flatnonzero(visible[i])
        noisy = pixels[i, seen] + rng.normal(0, sigma_px, (seen.size, 2))
        records.append(
            {
                "kind": "image",
                "joints": joints[i].tolist(),
                "camera": "hand",
                "points": [
                    {"target_mm": points[j].tolist(), "pixel": px.tolist()} for j, px in zip(seen, noisy, strict=True)
                ],
                "sigma_px": sigma_px,
            }
        )
    groups = read_images({"hand": {**INTRINSICS, "mount": "tool"}}, records)
    return CameraCampaign(truth, HAND_EYE_ROTATION, HAND_EYE_POSITION, groups, records)
