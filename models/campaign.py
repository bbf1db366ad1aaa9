"""A measurement campaign: joint readings and what the instrument saw, validated.

Internal units: joints in mm / rad, positions in mm (instrument frame),
orientations as unit quaternions `[w, x, y, z]` or absent (position-only
instrument, e.g. a laser tracker with one reflector).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from models._types import Array, first_nonfinite_record
from models.description.robot import RobotDescription
from models.description.terms import Conditions, condition_inputs
from models.errors import InvalidInput, InvalidQuaternion, NonFiniteValue, WrongShape
from models.kinematics import as_joint_array, check_joint_ranges
from models.measurement import MeasurementKind
from models.transforms import quaternion_to_matrix

QUATERNION_NORM_TOLERANCE = 1e-3
"""Quaternions whose norm is within this of 1 are normalised; others are rejected."""


@dataclass(frozen=True)
class Campaign:
    joints: Array
    """(N, n_joints), mm and rad."""
    positions: Array
    """(N, 3) measured TCP positions, mm, instrument frame."""
    quaternions: Array | None = None
    """(N, 4) measured TCP orientations `[w, x, y, z]`, unit norm; None for position-only data."""
    sigma_mm: Array | None = None
    """(N,) each record's own position σ (a tracker's U95 / 2, a per-point RMS), mm; None: the noise model's."""
    conditions: Conditions | None = None
    """What each record was measured under (temperature, payload): the inputs of the model terms."""

    @property
    def size(self) -> int:
        return int(self.joints.shape[0])

    @property
    def kind(self) -> MeasurementKind:
        return MeasurementKind.POSITION if self.quaternions is None else MeasurementKind.POSE

    @property
    def position_only(self) -> bool:
        return self.quaternions is None

    @cached_property
    def rotations(self) -> Array:
        """(N, 3, 3) the measured orientations, computed once (a fit reads them at every evaluation); read-only."""
        if self.quaternions is None:
            raise InvalidInput("a position-only campaign has no orientations", field="quaternions")
        rotations = quaternion_to_matrix(self.quaternions)
        rotations.setflags(write=False)
        return rotations

    def subset(self, index: ArrayLike) -> Campaign:
        idx = np.asarray(index)
        quats = None if self.quaternions is None else self.quaternions[idx]
        sigma = None if self.sigma_mm is None else self.sigma_mm[idx]
        cond = None if self.conditions is None else self.conditions.subset(idx)
        return Campaign(self.joints[idx], self.positions[idx], quats, sigma, cond)

    def condition_inputs(self, desc: RobotDescription) -> Array | None:
        """The (N, 7) conditions input of `desc`'s terms (None without terms); InvalidInput names what the
        terms need and the records lack (`temperature_c`, `payload`)."""
        if not desc.terms.any:
            return None
        return condition_inputs(desc.terms, self.conditions, self.size)


def make_campaign(
    desc: RobotDescription,
    joints: ArrayLike,
    positions: ArrayLike,
    quaternions: ArrayLike | None = None,
    *,
    check_ranges: bool = True,
    sigma_mm: ArrayLike | None = None,
    conditions: Conditions | None = None,
) -> Campaign:
    """Validate raw arrays (internal units) into a Campaign; domain errors name the offending record."""
    q = as_joint_array(desc, joints)
    if check_ranges:
        check_joint_ranges(desc, q, measured=True)
    p = _rows(positions, q.shape[0], 3, field="positions", rows_are="positions of 3 numbers", what="position")
    sigma = None if sigma_mm is None else _sigmas(sigma_mm, q.shape[0])
    if conditions is not None:
        _check_conditions(conditions, q.shape[0])
    if quaternions is None:
        return Campaign(q, p, None, sigma, conditions)
    quat = _rows(
        quaternions,
        q.shape[0],
        4,
        field="quaternions",
        rows_are="orientations of 4 numbers [w, x, y, z]",
        what="orientation",
    )
    norms = np.linalg.norm(quat, axis=1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > QUATERNION_NORM_TOLERANCE)
    if bad.size:
        i = int(bad[0])
        raise InvalidQuaternion(
            f"record {i}: orientation quaternion has norm {norms[i]:.6g}; a unit quaternion [w, x, y, z] is "
            f"required (norms within {QUATERNION_NORM_TOLERANCE} of 1 are normalised)",
            pose=i,
            norm=float(norms[i]),
            count=int(bad.size),
        )
    return Campaign(q, p, quat / norms[:, None], sigma, conditions)


def _check_conditions(conditions: Conditions, n: int) -> None:
    for name, value in (
        ("temperature_c", conditions.temperature_c),
        ("payload.mass_kg", conditions.payload_kg),
        ("payload.cog_mm", conditions.payload_cog_mm),
    ):
        if value is not None and value.shape[0] != n:
            raise WrongShape(
                f"expected {n} values of {name} (one per record), got {value.shape[0]}",
                field=name,
                expected=[n],
                got=[int(value.shape[0])],
            )


def _sigmas(sigma_mm: ArrayLike, n: int) -> Array:
    sigma = np.array(sigma_mm, dtype=float).reshape(-1)
    if sigma.shape != (n,):
        raise WrongShape(
            f"expected {n} position uncertainties (one per record), got {sigma.size}",
            field="sigma_mm",
            expected=[n],
            got=list(sigma.shape),
        )
    bad = np.flatnonzero(~(np.isfinite(sigma) & (sigma > 0)))
    if bad.size:
        i = int(bad[0])
        raise InvalidInput(
            f"record {i}: sigma_mm must be a positive number of millimetres, got {sigma[i]}",
            field="sigma_mm",
            value=float(sigma[i]) if np.isfinite(sigma[i]) else None,
            min=0.0,
        )
    return sigma


def _rows(values: ArrayLike, n: int, width: int, *, field: str, rows_are: str, what: str) -> Array:
    """`values` as (n, width) finite numbers, one row a record (a single record may come flat), or the error
    naming the shape expected (`n` `rows_are`) or the first record that is not finite (its `what`)."""
    rows = np.array(values, dtype=float)
    if rows.ndim == 1:
        rows = rows[None, :]
    if rows.shape != (n, width):
        raise WrongShape(
            f"expected {n} {rows_are}, got shape {rows.shape}", field=field, expected=[n, width], got=list(rows.shape)
        )
    _check_finite(rows, what)
    return rows


def _check_finite(a: Array, what: str) -> None:
    i = first_nonfinite_record(a)
    if i is not None:
        raise NonFiniteValue(f"record {i}: {what} contains {a[i].tolist()}, not finite numbers", pose=i)
