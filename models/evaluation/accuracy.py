"""How accurate a parameter version is, measured on poses that were not used to fit it (ISO 9283 where they repeat).

`evaluate` compares each measured record with the version's forward kinematics of its joints: per-pose position
and orientation errors, RMS, max and percentiles; records with the same joint command are the cycles of one
ISO 9283 pose (AP, RP, orientation AP/RP), and consecutive repeated poses with equal cycle counts give distance
accuracy AD / RD. `iso_cube_poses` proposes the standard's test: the largest cube around the centre of the
reachable workspace whose corners the robot reaches at one orientation, and the joint commands of P1…P5.
Internal units (mm, rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models._types import Array
from models.campaign import Campaign
from models.compensation import inverse_kinematics
from models.description.robot import RobotDescription
from models.engine.runtime import Runtime, runtime_for
from models.errors import InvalidInput
from models.evaluation.iso9283 import (
    DistanceCharacteristics,
    IsoCube,
    PoseCharacteristics,
    distance_characteristics,
    group_cycles,
    iso_cube,
    pose_characteristics,
)
from models.identification.registration import rigid_fit
from models.kinematics import forward_kinematics
from models.transforms import matrix_to_quaternion, quaternion_to_matrix
from models.workspace import sample_workspace

PERCENTILES = (50.0, 90.0, 95.0, 99.0)
CUBE_SAMPLES = 2000
CUBE_SEED = 9283
CUBE_BISECTIONS = 12


@dataclass(frozen=True)
class IsoPose:
    joints: Array
    """(n_joints,) the repeated command, internal units."""
    records: tuple[int, ...]
    characteristics: PoseCharacteristics


@dataclass(frozen=True)
class IsoDistance:
    poses: tuple[int, int]
    """Indices into `AccuracyReport.iso_poses`."""
    characteristics: DistanceCharacteristics


@dataclass(frozen=True)
class AccuracyReport:
    position_mm: Array
    """(N,) |measured − predicted| per record."""
    orientation_rad: Array | None
    """(N,) rotation angle between measured and predicted orientation, when measured."""
    registered: bool
    """True when the instrument frame was fitted first (a version from another station, or the nominal one)."""
    iso_poses: tuple[IsoPose, ...]
    iso_distances: tuple[IsoDistance, ...]

    @property
    def rms_mm(self) -> float:
        return float(np.sqrt(np.mean(self.position_mm**2)))

    @property
    def max_mm(self) -> float:
        return float(self.position_mm.max())

    def percentiles_mm(self) -> dict[float, float]:
        return {p: float(np.percentile(self.position_mm, p)) for p in PERCENTILES}

    @property
    def rms_rad(self) -> float | None:
        return None if self.orientation_rad is None else float(np.sqrt(np.mean(self.orientation_rad**2)))

    @property
    def max_rad(self) -> float | None:
        return None if self.orientation_rad is None else float(self.orientation_rad.max())


def evaluate(
    desc: RobotDescription, params: Array, campaign: Campaign, *, register: bool = False, runtime: Runtime | None = None
) -> AccuracyReport:
    """The version `params` against `campaign`; with `register`, first the best rigid fit of the instrument frame."""
    campaign.condition_inputs(desc)  # a version with model terms needs the records' temperatures (payloads)
    fk = forward_kinematics(  # its joints were checked as readings when the campaign was made (make_campaign)
        desc,
        campaign.joints,
        params,
        check_ranges=False,
        conditions=campaign.conditions,
        runtime=runtime_for(desc, runtime),
    )
    predicted, rotations = fk.positions, fk.rotations
    if register:
        fit = rigid_fit(predicted, campaign.positions)
        predicted = fit.apply(predicted)
        rotations = np.einsum("ij,njk->nik", fit.rotation, rotations)
    position = np.linalg.norm(campaign.positions - predicted, axis=1)
    orientation = None
    measured_rotations = None
    if campaign.quaternions is not None:
        measured_rotations = quaternion_to_matrix(campaign.quaternions)
        cos = (np.einsum("nij,nij->n", measured_rotations, rotations) - 1.0) / 2.0
        orientation = np.arccos(np.clip(cos, -1.0, 1.0))
    poses = []
    for group in group_cycles(campaign.joints):
        if group.size < 2:
            continue
        k = int(group[0])
        characteristics = pose_characteristics(
            predicted[k],
            campaign.positions[group],
            rotations[k] if measured_rotations is not None else None,
            measured_rotations[group] if measured_rotations is not None else None,
        )
        poses.append(IsoPose(campaign.joints[k].copy(), tuple(int(i) for i in group), characteristics))
    distances = []
    for a in range(len(poses) - 1):
        first, second = poses[a], poses[a + 1]
        if len(first.records) == len(second.records):
            distances.append(
                IsoDistance(
                    (a, a + 1),
                    distance_characteristics(
                        first.characteristics.commanded_position,
                        second.characteristics.commanded_position,
                        campaign.positions[list(first.records)],
                        campaign.positions[list(second.records)],
                    ),
                )
            )
    return AccuracyReport(position, orientation, register, tuple(poses), tuple(distances))


@dataclass(frozen=True)
class CubePoses:
    cube: IsoCube
    """In the frame of `params` (after a calibration: the instrument's)."""
    orientation: Array
    """(4,) the one TCP orientation of all five poses, `[w, x, y, z]`."""
    joints: Array
    """(5, n_joints) commands of P1…P5 from the model `params`, internal units."""


def iso_cube_poses(
    desc: RobotDescription, params: Array, *, seed: int = CUBE_SEED, runtime: Runtime | None = None
) -> CubePoses:
    """The ISO 9283 cube: centred on the reachable workspace's centre, as large as the robot reaches all eight
    corners (and P1…P5) at the orientation it has there; P1…P5 as joint commands of the model `params`."""
    rt = runtime_for(desc, runtime)
    joints = sample_workspace(desc, CUBE_SAMPLES, seed=seed, runtime=rt)
    fk = forward_kinematics(desc, joints, params, runtime=rt)
    centre = np.median(fk.positions, axis=0)
    nearest = int(np.argmin(np.linalg.norm(fk.positions - centre, axis=1)))
    quaternion = matrix_to_quaternion(fk.rotations[nearest])
    extent = float(np.min(np.percentile(fk.positions, 95, axis=0) - np.percentile(fk.positions, 5, axis=0)))

    def reachable(edge: float) -> tuple[bool, Array]:
        cube = iso_cube(centre, edge)
        targets = np.vstack([cube.points, cube.corners])
        answer = inverse_kinematics(
            desc,
            targets,
            np.repeat(quaternion[None, :], len(targets), axis=0),
            params,
            seed=joints[nearest],
            runtime=rt,
        )
        return bool(answer.reachable.all()), answer.joints[: len(cube.points)]

    lo, hi = 0.0, extent
    best: Array | None = None
    for _ in range(CUBE_BISECTIONS):
        mid = (lo + hi) / 2
        ok, commands = reachable(mid)
        if ok:
            lo, best = mid, commands
        else:
            hi = mid
    if best is None or lo <= 0:
        raise InvalidInput("no ISO 9283 cube fits the reachable workspace at one orientation")
    return CubePoses(iso_cube(centre, lo), quaternion, best)
