"""Performance criteria of ISO 9283 (manipulating industrial robots): pose and distance accuracy and repeatability.

Pure numpy over attained poses (what the instrument measured, n cycles of one command) and commanded poses (what
the model in question predicts for the commanded joints). Internal units: mm and radians.

- Pose accuracy (§7.2.1): AP_P = |x̄ − x_c|, the distance from the barycentre of the attained positions to the
  commanded position, with its components AP_x, AP_y, AP_z; orientation accuracy AP_a, AP_b, AP_c = mean attained
  angle − commanded angle, for the angles a, b, c about x, y, z (R = Rz(c)·Ry(b)·Rx(a)).
- Pose repeatability (§7.2.2): RP_l = l̄ + 3 S_l with l_j = |x_j − x̄| and S_l the sample standard deviation of the
  l_j (n − 1 in the denominator); orientation repeatability RP_a = 3 S_a (and b, c alike).
- Distance accuracy (§7.3): AD = D̄ − D_c between two commanded poses, D_j the attained distance in cycle j;
  distance repeatability RD = 3 S_D.
- The test cube (§6.2): a cube in the workspace, measured in the diagonal plane C1–C2–C7–C8; P1 at its centre,
  P2…P5 on the plane's diagonals at 10 % of the diagonal's length from the corners C1, C2, C7, C8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from models.errors import InvalidInput, WrongShape

Array = NDArray[np.float64]

CUBE_POINT_FRACTION = 0.1
"""ISO 9283 §6.2: P2…P5 lie on the diagonals at (10 ± 2) % of the diagonal's length from the corners."""


def abc_angles(rotations: ArrayLike) -> Array:
    """(n, 3, 3) rotation matrices → (n, 3) angles a, b, c (rad) with R = Rz(c)·Ry(b)·Rx(a)."""
    r = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
    b = np.arcsin(np.clip(-r[:, 2, 0], -1.0, 1.0))
    a = np.arctan2(r[:, 2, 1], r[:, 2, 2])
    c = np.arctan2(r[:, 1, 0], r[:, 0, 0])
    return np.stack([a, b, c], axis=1)


def _wrapped(angles: Array) -> Array:
    """Angle differences into (−π, π]: a command at 179° and a reading at −179° are 2° apart, not 358°."""
    return np.asarray(np.pi - np.mod(np.pi - angles, 2 * np.pi), dtype=float)


def _sample_std(values: Array, axis: int = 0) -> Array:
    return np.asarray(np.std(values, axis=axis, ddof=1), dtype=float)


@dataclass(frozen=True)
class PoseCharacteristics:
    """ISO 9283 accuracy and repeatability of one commanded pose over its cycles."""

    commanded_position: Array
    """(3,) mm."""
    barycentre: Array
    """(3,) mean attained position, mm."""
    cycles: int
    accuracy_mm: float
    """AP_P."""
    accuracy_xyz_mm: Array
    """(3,) AP_x, AP_y, AP_z: barycentre − command."""
    repeatability_mm: float
    """RP_l = l̄ + 3 S_l."""
    orientation_accuracy_rad: Array | None
    """(3,) AP_a, AP_b, AP_c, when orientations were measured."""
    orientation_repeatability_rad: Array | None
    """(3,) RP_a, RP_b, RP_c = 3 S_a, 3 S_b, 3 S_c."""


def pose_characteristics(
    commanded_position: ArrayLike,
    attained_positions: ArrayLike,
    commanded_rotation: ArrayLike | None = None,
    attained_rotations: ArrayLike | None = None,
) -> PoseCharacteristics:
    """AP and RP of one pose from its n ≥ 2 cycles (ISO 9283 §7.2)."""
    command = np.asarray(commanded_position, dtype=float).reshape(3)
    attained = np.asarray(attained_positions, dtype=float)
    if attained.ndim != 2 or attained.shape[1] != 3:
        raise WrongShape(f"attained positions must be (n, 3), got {attained.shape}")
    n = attained.shape[0]
    if n < 2:
        raise InvalidInput(f"ISO 9283 repeatability needs at least 2 cycles of a pose, got {n}")
    barycentre = attained.mean(axis=0)
    offsets = np.linalg.norm(attained - barycentre, axis=1)
    orientation_accuracy = orientation_repeatability = None
    if commanded_rotation is not None and attained_rotations is not None:
        command_abc = abc_angles(commanded_rotation)[0]
        attained_abc = abc_angles(attained_rotations)
        if attained_abc.shape[0] != n:
            raise WrongShape(f"{attained_abc.shape[0]} attained orientations for {n} attained positions")
        # Angles relative to the command first, so a pose near ±180° averages without wrapping artefacts.
        relative = _wrapped(attained_abc - command_abc)
        orientation_accuracy = relative.mean(axis=0)
        orientation_repeatability = 3.0 * _sample_std(relative)
    return PoseCharacteristics(
        commanded_position=command,
        barycentre=barycentre,
        cycles=n,
        accuracy_mm=float(np.linalg.norm(barycentre - command)),
        accuracy_xyz_mm=barycentre - command,
        repeatability_mm=float(offsets.mean() + 3.0 * _sample_std(offsets)),
        orientation_accuracy_rad=orientation_accuracy,
        orientation_repeatability_rad=orientation_repeatability,
    )


@dataclass(frozen=True)
class DistanceCharacteristics:
    """ISO 9283 distance accuracy and repeatability between two commanded poses."""

    commanded_mm: float
    """D_c."""
    mean_attained_mm: float
    """D̄."""
    accuracy_mm: float
    """AD = D̄ − D_c."""
    repeatability_mm: float
    """RD = 3 S_D."""
    cycles: int


def distance_characteristics(
    commanded_a: ArrayLike, commanded_b: ArrayLike, attained_a: ArrayLike, attained_b: ArrayLike
) -> DistanceCharacteristics:
    """AD and RD (ISO 9283 §7.3) from n ≥ 2 paired cycles of two poses."""
    a, b = (np.asarray(p, dtype=float) for p in (attained_a, attained_b))
    if a.shape != b.shape or a.ndim != 2 or a.shape[1] != 3:
        raise WrongShape(f"attained positions of the two poses must both be (n, 3), got {a.shape} and {b.shape}")
    if a.shape[0] < 2:
        raise InvalidInput(f"ISO 9283 distance repeatability needs at least 2 cycles, got {a.shape[0]}")
    commanded = float(np.linalg.norm(np.asarray(commanded_a, float) - np.asarray(commanded_b, float)))
    attained = np.linalg.norm(a - b, axis=1)
    return DistanceCharacteristics(
        commanded_mm=commanded,
        mean_attained_mm=float(attained.mean()),
        accuracy_mm=float(attained.mean() - commanded),
        repeatability_mm=float(3.0 * _sample_std(attained)),
        cycles=int(a.shape[0]),
    )


def group_cycles(joints: ArrayLike, tolerance: float = 1e-9) -> list[NDArray[np.intp]]:
    """Records whose joint commands are equal (to `tolerance`, internal units) are the cycles of one pose.

    Groups come in the order of their first record; each holds the record indices in campaign order.
    """
    q = np.asarray(joints, dtype=float)
    groups: list[list[int]] = []
    leaders: list[Array] = []
    for i, row in enumerate(q):
        for g, leader in enumerate(leaders):
            if np.max(np.abs(row - leader)) <= tolerance:
                groups[g].append(i)
                break
        else:
            leaders.append(row)
            groups.append([i])
    return [np.asarray(g, dtype=np.intp) for g in groups]


@dataclass(frozen=True)
class IsoCube:
    """The ISO 9283 cube: corners C1…C8 and the measuring points P1…P5 (mm, in the frame it was given in)."""

    centre: Array
    edge_mm: float
    corners: Array
    """(8, 3) C1…C8: C1 (−,−,−), C2 (+,−,−), C3 (+,+,−), C4 (−,+,−), C5 (−,−,+), C6 (+,−,+), C7 (+,+,+),
    C8 (−,+,+) in the cube's axes; the measuring plane C1–C2–C7–C8 holds two opposite edges."""
    points: Array
    """(5, 3) P1 (centre), then P2…P5 at 10 % of the diagonal from C1, C2, C7, C8."""


def iso_cube(centre: ArrayLike, edge_mm: float, rotation: ArrayLike | None = None) -> IsoCube:
    """The cube of the standard, centred at `centre`, with edges along `rotation`'s columns (default: the frame's)."""
    c = np.asarray(centre, dtype=float).reshape(3)
    if not (np.isfinite(edge_mm) and edge_mm > 0):
        raise InvalidInput(f"the cube's edge must be a positive length, got {edge_mm}")
    r = np.eye(3) if rotation is None else np.asarray(rotation, dtype=float).reshape(3, 3)
    signs = np.array(
        [[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float
    )
    corners = c + (signs * edge_mm / 2) @ r.T
    c1, c2, c7, c8 = corners[0], corners[1], corners[6], corners[7]
    opposite = {0: c7, 1: c8, 6: c1, 7: c2}  # the other end of each corner's diagonal in the plane
    near = [corners[i] + CUBE_POINT_FRACTION * (opposite[i] - corners[i]) for i in (0, 1, 6, 7)]
    centre_of_plane = (c1 + c2 + c7 + c8) / 4
    return IsoCube(centre=c, edge_mm=float(edge_mm), corners=corners, points=np.vstack([centre_of_plane, *near]))
