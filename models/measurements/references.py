"""Measurements against a fixed reference the cell owns, not an instrument frame: each record pins the TCP's
position to an unknown feature that the fit identifies with the robot's parameters.

- `Anchor` (a ballbar's centre pivot, a wire or laser sensor's origin): the record is the TCP's distance to the
  anchor point, `‖p − a‖`, plus an unknown length offset when the bar's length is not known
  (`length_unknown`): r = ‖p − a‖ − (d + δ). Unknowns: a (3), δ (1, optional).
- `FixedPoint` (a sphere in a socket, reached in several orientations): the TCP is on the same point c in
  every record, r = p − c (3 rows). Unknowns: c (3).
- `Plane` (a probe's ball centre, its radius already added, touching one plate): r = n · p − h, with the unit
  normal n turned from its start n₀ by two small angles (α about e₁, β about e₂, both ⟂ n₀) so that three
  numbers describe it without a constraint. Unknowns: α, β (rad), h (mm).
- `Reflector` (a second or third tracker reflector on the tool, beside the one the TCP is): the tracker's
  reading of a point fixed in the TCP frame at an unknown offset o, r = p + R o − m (3 rows). Unknowns: o (3).
  Unlike the others it sees the tracker's frame, and with the TCP's own records it sees the tool's orientation:
  three reflectors read at once give what a 6-DOF probe gives.

Each of the first three depends on the TCP position p(q, θ) alone, so its rows and their θ-derivatives come from the
position rows of the forward kinematics and its Jacobian; the derivatives by its own unknowns are written out
here (a test checks them against finite differences). None of them fixes a frame: the base transform moves
every anchor, point and plane with it (`fixes_frame`). A reference receives the whole TCP pose (positions,
rotations and the 6-row Jacobian of `forward_kinematics(..., jacobian=True)`), because a camera
(`models.measurements.camera`) sees the tool's orientation as well.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import ClassVar, Protocol, TypeAlias, cast

import numpy as np
from numpy.typing import NDArray

from models._types import Array
from models.description.parameters import Kind, ParameterSpec
from models.errors import InvalidInput, TooFewMeasurements
from models.kinematics import ForwardJacobianResult, ForwardResult

POSITION_SCALE_MM = 1.0
"""The expected error of a reference's start position (mm), the scale of its columns (as a link length's)."""
ANGLE_SCALE_RAD = 1e-3
"""A plane normal's expected start error (rad)."""
FAILING_SIGMA = 5.0
"""A touch fails its plane beyond this many σ (a clean touch does not, a step of a tenth of a mm does)."""
MIN_OTHER_TOUCHES = 4
"""Touches needed before their own plane means anything (three always lie on one)."""
OWN_PLANE_SIGMA = 3.0
"""Touches on one face of their own fit it to within a few σ (RMS)."""
MIN_PLANE_SPREAD_MM = 5.0
"""A plane's touches must spread at least this (RMS) across their best line, or its tilt about that line is
not determined (a plate is touched over tens of millimetres)."""


@dataclass(frozen=True)
class Traits:
    """What a kind of reference is, the same for every reference of it."""

    kind: str
    """As records and messages name it: "anchor", "point", "plane", "position"."""
    rows: int
    """Equations a record gives."""
    value_columns: int
    """Measured numbers per record: a distance 1, a tracker's position 3, a point or a plane touch 0."""
    fixes_frame: bool
    """Whether its records see the instrument frame (a tracker's do; a reference's move with the base)."""
    fixes_scale: bool
    """Whether its records carry a length (a distance does; coincidence with a point or a plane does not: the
    whole robot and its points and planes scaled together satisfy them as well)."""
    sigma_unit: str = "mm"
    """The unit of its residual and of a record's σ; a reference whose unit is not the noise model's (mm) needs
    σ given with its records."""
    registers_frame: bool = False
    """Whether its measured values are the TCP's own positions in the frame it fixes (a tracker's): the fit then
    starts from the base registered to them in closed form (the instrument may stand metres away and turned)."""
    position_error: bool = False
    """Whether a record's error is a position in mm (‖r‖ of a point seen in a frame: a tracker's, a reflector's,
    a socket's): a fresh record's predicted error is then given beside the TCP's."""
    recorded_as: str | None = None
    """The kind of record that measures it as the contract names it, where that is not `kind` ("distance" for
    an anchor)."""

    @property
    def record_kind(self) -> str:
        """The kind of record that measures it (a report's `record_kinds`)."""
        return self.kind if self.recorded_as is None else self.recorded_as


@dataclass(frozen=True)
class Misfit:
    """What a reference's records betray after the fit that no pre-fit check could see (a plane touched on two
    faces): the finding (a `models.identification.diagnosis.Finding` value), the records by their places in the
    campaign and the message naming the fix."""

    finding: str
    records: tuple[int, ...]
    message: str


class Reference(Protocol):
    """One reference feature and what a record against it says (see the module docstring)."""

    traits: ClassVar[Traits]

    @property
    def name(self) -> str:
        """As records and messages name it (its parameters' middle part: `anchor.<name>.x`)."""
        ...

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        """Its own parameters (named `<kind>.<name>.<component>`), with their start values and scales."""
        ...

    @property
    def minimum_records(self) -> int:
        """Records needed before it can be determined at all (its unknowns, counted in rows)."""
        ...

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        """At the records' TCP poses `tcp` (positions p (n, 3), rotations (n, 3, 3), jacobians (n, 6, P): ∂p/∂θ
        then the world-frame rotation per unit θ, dR = [dω]× R), its unknowns u and the records' measured values:
        (r (n, rows), ∂r/∂θ (n, rows, P), ∂r/∂u (n, rows, len(u))), model minus measurement, unweighted."""
        ...

    def started(self, tcp: ForwardResult, values: Array) -> Reference:
        """The same reference with its start computed in closed form from the records' TCP poses under the start
        model: what the fit iterates from (a user's rough guess is not needed)."""
        ...

    def errors_mm(self, tcp: ForwardResult, u: Array, values: Array) -> Array:
        """Each record's error in mm (a row per record; an image's point per row): what a report and a check
        state of it (`ReferenceBase`: ‖r‖ of its residual)."""
        ...

    def misfits(self, tcp: ForwardResult, u: Array, sigma_mm: Array, places: NDArray[np.intp]) -> tuple[Misfit, ...]:
        """What its records betray at the fit's solution (`tcp` at the fitted robot, `u` its fitted unknowns,
        each record's σ and its place in the campaign); none for most kinds (`ReferenceBase`)."""
        ...


class ReferenceBase:
    """What most kinds of reference answer alike (a kind overrides what it answers otherwise)."""

    def errors_mm(self, tcp: ForwardResult, u: Array, values: Array) -> Array:
        """‖r‖ of each record's residual: a distance's or a touch's |r|, a point's or a position's ‖r‖ (mm)."""
        own = cast(Reference, self)
        # No derivatives are needed: an empty Jacobian keeps the residuals' own shapes.
        n = tcp.positions.shape[0]
        empty = ForwardJacobianResult(tcp.positions, tcp.rotations, tcp.platforms, np.zeros((n, 6, 0)))
        r, _, _ = own.residuals(empty, u, values)
        return np.asarray(np.linalg.norm(r, axis=1))

    def misfits(self, tcp: ForwardResult, u: Array, sigma_mm: Array, places: NDArray[np.intp]) -> tuple[Misfit, ...]:
        return ()


def position_specs(prefix: str, start: Array) -> tuple[ParameterSpec, ...]:
    """A point's unknowns `<prefix>.x`, `.y`, `.z` (mm), started at `start`."""
    return tuple(
        ParameterSpec(f"{prefix}.{axis}", prefix, Kind.LENGTH, float(v), POSITION_SCALE_MM)
        for axis, v in zip("xyz", start, strict=True)
    )


def direction_specs(prefix: str) -> tuple[ParameterSpec, ...]:
    """A direction's unknowns `<prefix>.alpha`, `.beta`: the two small angles that turn its start (rad, from 0;
    `Plane.normal_at`)."""
    return tuple(
        ParameterSpec(f"{prefix}.{angle}", prefix, Kind.ANGLE, 0.0, ANGLE_SCALE_RAD) for angle in ("alpha", "beta")
    )


@dataclass(frozen=True)
class Anchor(ReferenceBase):
    """A fixed point the records measure the TCP's distance to; `start` its position guess (mm, the robot's
    world frame), `length_unknown` a ballbar whose length offset δ is identified too."""

    name: str
    start: tuple[float, float, float]
    length_unknown: bool = False

    traits: ClassVar[Traits] = Traits(
        "anchor", rows=1, value_columns=1, fixes_frame=False, fixes_scale=True, recorded_as="distance"
    )

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        specs = position_specs(f"anchor.{self.name}", np.asarray(self.start))
        if self.length_unknown:
            specs += (ParameterSpec(f"anchor.{self.name}.length", f"anchor.{self.name}", Kind.LENGTH, 0.0, 1.0),)
        return specs

    @property
    def minimum_records(self) -> int:
        return len(self.unknowns) + 1

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        p, dp = tcp.positions, tcp.jacobians[:, :3, :]
        offset = p - u[:3]
        length = np.linalg.norm(offset, axis=1)
        if np.any(length < 1e-9):
            raise InvalidInput(f"anchor {self.name!r}: a record puts the TCP on the anchor itself", field="anchors")
        unit = offset / length[:, None]
        delta = u[3] if self.length_unknown else 0.0
        r = (length - (values + delta))[:, None]
        d_theta = np.einsum("nk,nkp->np", unit, dp)[:, None, :]
        d_u = -unit
        if self.length_unknown:
            d_u = np.hstack([d_u, -np.ones((p.shape[0], 1))])
        return r, d_theta, d_u[:, None, :]

    def started(self, tcp: ForwardResult, values: Array) -> Anchor:
        p = tcp.positions
        centre, misfit = _sphere(p, values)
        # A bar read in another unit fits no sphere around any point; scaled back it fits one, as a bar must.
        for unit, factor in DISTANCE_SLIPS.items():
            _, scaled = _sphere(p, values * factor)
            if misfit > SLIP_MISFIT_MM and scaled < SLIP_RATIO * misfit:
                raise InvalidInput(
                    f"anchor {self.name!r}: the distances look like {unit} ({values.mean():.4g} on average; times "
                    f"{factor:g} they fit a sphere to {scaled:.2g} mm RMS, as given to {misfit:.3g} mm): give them in "
                    "mm",
                    field="measurements",
                    reason="distance_unit",
                    value=unit,
                )
        x, y, z = (float(v) for v in centre)
        return Anchor(self.name, (x, y, z), self.length_unknown)


DISTANCE_SLIPS = {"inches": 25.4, "metres": 1000.0, "centimetres": 10.0}
"""Units a distance file slips into, and their factor to mm."""
SLIP_MISFIT_MM = 1.0
"""A sphere misfit the nominal model's errors cannot explain (they are tenths of a millimetre) ..."""
SLIP_RATIO = 0.1
"""... and that the rescaled distances cut tenfold: then the unit is named, not fitted."""


def _sphere(p: Array, d: Array) -> tuple[Array, float]:
    """The sphere through the records: its centre and the RMS misfit of the distances to it (mm).

    ‖p − a‖² = d²  ⇔  2 p·a − ‖a‖² = ‖p‖² − d²: linear in (a, ‖a‖²); the misfit is that of the distances."""
    matrix = np.hstack([2 * p, -np.ones((p.shape[0], 1))])
    solution, *_ = np.linalg.lstsq(matrix, np.sum(p**2, axis=1) - d**2, rcond=None)
    centre = solution[:3]
    misfit = float(np.sqrt(np.mean((np.linalg.norm(p - centre, axis=1) - d) ** 2)))
    return centre, misfit


@dataclass(frozen=True)
class FixedPoint(ReferenceBase):
    """A point the TCP is brought onto in every record of it (no instrument reading at all)."""

    name: str
    start: tuple[float, float, float]

    traits: ClassVar[Traits] = Traits(
        "point", rows=3, value_columns=0, fixes_frame=False, fixes_scale=False, position_error=True
    )

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        return position_specs(f"point.{self.name}", np.asarray(self.start))

    @property
    def minimum_records(self) -> int:
        return 2

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        p, n = tcp.positions, tcp.positions.shape[0]
        return p - u[None, :3], tcp.jacobians[:, :3, :].copy(), np.broadcast_to(-np.eye(3), (n, 3, 3)).copy()

    def started(self, tcp: ForwardResult, values: Array) -> FixedPoint:
        x, y, z = (float(v) for v in tcp.positions.mean(axis=0))
        return FixedPoint(self.name, (x, y, z))


@dataclass(frozen=True)
class Plane(ReferenceBase):
    """A plate the probe touches; `normal` and `offset` its start (n₀ unit, h₀ = n₀ · a point on it, mm)."""

    name: str
    normal: tuple[float, float, float]
    offset: float

    traits: ClassVar[Traits] = Traits("plane", rows=1, value_columns=0, fixes_frame=False, fixes_scale=False)

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        group = f"plane.{self.name}"
        offset = ParameterSpec(f"{group}.offset", group, Kind.LENGTH, float(self.offset), POSITION_SCALE_MM)
        return (*direction_specs(group), offset)

    @property
    def minimum_records(self) -> int:
        return 4

    def basis(self) -> tuple[Array, Array, Array]:
        """(n₀, e₁, e₂): the start normal and two unit vectors completing a right-handed frame."""
        n0 = np.asarray(self.normal, dtype=float)
        n0 = n0 / np.linalg.norm(n0)
        helper = np.eye(3)[int(np.argmin(np.abs(n0)))]
        e1 = np.cross(n0, helper)
        e1 /= np.linalg.norm(e1)
        return n0, e1, np.cross(n0, e1)

    def normal_at(self, alpha: float, beta: float) -> tuple[Array, Array, Array]:
        """(n, ∂n/∂α, ∂n/∂β) of n = v / ‖v‖, v = n₀ + α e₁ + β e₂."""
        n0, e1, e2 = self.basis()
        v = n0 + alpha * e1 + beta * e2
        norm = float(np.linalg.norm(v))
        n = v / norm
        project = (np.eye(3) - np.outer(n, n)) / norm
        return n, project @ e1, project @ e2

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        p, dp = tcp.positions, tcp.jacobians[:, :3, :]
        n, dn_a, dn_b = self.normal_at(float(u[0]), float(u[1]))
        r = (p @ n - u[2])[:, None]
        d_theta = np.einsum("k,nkp->np", n, dp)[:, None, :]
        d_u = np.stack([p @ dn_a, p @ dn_b, -np.ones(p.shape[0])], axis=1)[:, None, :]
        return r, d_theta, d_u

    def misfits(self, tcp: ForwardResult, u: Array, sigma_mm: Array, places: NDArray[np.intp]) -> tuple[Misfit, ...]:
        """Touches that fail the plane and lie, among themselves, on another plane: another face was touched
        under this name (the probe slipped onto a step, two plates at one height named alike). Named with the
        records, the offset and the tilt between the two, so that the user gives them their own name."""
        normal, _, _ = self.normal_at(float(u[0]), float(u[1]))
        signed = tcp.positions @ normal - float(u[2])
        failing = np.flatnonzero(np.abs(signed) > FAILING_SIGMA * sigma_mm)
        if failing.size < MIN_OTHER_TOUCHES:
            return ()
        other, misfit = _best_plane(tcp.positions[failing])
        if misfit > OWN_PLANE_SIGMA * float(np.median(sigma_mm[failing])):
            return ()
        tilt = math.degrees(math.acos(min(1.0, abs(float(other @ normal)))))
        records = tuple(int(i) for i in places[failing])
        message = (
            f"{failing.size} touches of plane {self.name!r} (records {list(records[:10])}) lie on another plane "
            f"{float(np.mean(signed[failing])):+.3g} mm from it and tilted {tilt:.2g}° (they fit it to "
            f"{misfit * 1000:.2g} µm RMS): another face was touched under this name; give those touches their "
            "own plane"
        )
        return (Misfit("other_plane", records, message),)

    def started(self, tcp: ForwardResult, values: Array) -> Plane:
        p = tcp.positions
        centre = p.mean(axis=0)
        _, s, vt = np.linalg.svd(p - centre)
        across = float(s[1]) / np.sqrt(p.shape[0]) if s.size > 1 else 0.0
        if across < MIN_PLANE_SPREAD_MM:
            raise InvalidInput(
                f"plane {self.name!r}: every touch lies on one line (they spread {across:.2g} mm RMS across it); "
                f"touch it over an area, at least {MIN_PLANE_SPREAD_MM:g} mm either side of any line",
                field="measurements",
                reason="collinear_touches",
            )
        normal = vt[2] if np.dot(vt[2], np.asarray(self.normal)) >= 0 else -vt[2]  # the user's side of the plate
        nx, ny, nz = (float(v) for v in normal)
        return Plane(self.name, (nx, ny, nz), float(normal @ centre))


@dataclass(frozen=True)
class TrackerPositions(ReferenceBase):
    """Positions a tracker measured in its own frame (the robot's `base` is that frame), in a campaign with
    references: residual p − m (3 rows), no unknowns of its own, and it fixes the frame and the length."""

    name: str = "tracker"

    traits: ClassVar[Traits] = Traits(
        "position",
        rows=3,
        value_columns=3,
        fixes_frame=True,
        fixes_scale=True,
        registers_frame=True,
        position_error=True,
    )

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        return ()

    @property
    def minimum_records(self) -> int:
        return 1

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        p = tcp.positions
        return p - values, tcp.jacobians[:, :3, :].copy(), np.zeros((p.shape[0], 3, 0))

    def started(self, tcp: ForwardResult, values: Array) -> TrackerPositions:
        return self


@dataclass(frozen=True)
class Reflector(ReferenceBase):
    """A tracker reflector fixed on the tool at `offset` from the TCP (mm, in the TCP frame: its start), read by
    the tracker in its own frame like the TCP's records (`TrackerPositions`)."""

    name: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)

    traits: ClassVar[Traits] = Traits(
        "reflector", rows=3, value_columns=3, fixes_frame=True, fixes_scale=True, position_error=True
    )

    @property
    def unknowns(self) -> tuple[ParameterSpec, ...]:
        return position_specs(f"reflector.{self.name}", np.asarray(self.offset))

    @property
    def minimum_records(self) -> int:
        return 2

    def residuals(self, tcp: ForwardJacobianResult, u: Array, values: Array) -> tuple[Array, Array, Array]:
        # p + R o: its θ-derivative is ∂p/∂θ + [dω]× (R o) = ∂p/∂θ − [R o]× ∂ω/∂θ (rows 3-5 of the jacobian).
        rotations = tcp.rotations
        arm = np.einsum("nij,j->ni", rotations, u[:3])
        d_theta = tcp.jacobians[:, :3, :] - np.einsum("nij,njp->nip", _cross_matrices(arm), tcp.jacobians[:, 3:6, :])
        return tcp.positions + arm - values, d_theta, rotations.copy()

    def started(self, tcp: ForwardResult, values: Array) -> Reflector:
        # R o = m − p in every record: o is the mean of Rᵀ (m − p) under the start model (the tracker's frame
        # registered from the TCP's records; where it is off, the fit moves o with it).
        x, y, z = (float(v) for v in np.einsum("nji,nj->ni", tcp.rotations, values - tcp.positions).mean(axis=0))
        return Reflector(self.name, (x, y, z))


def _best_plane(points: Array) -> tuple[Array, float]:
    """The plane through `points` (least squares): its unit normal and the RMS distance of the points from it."""
    centred = points - points.mean(axis=0)
    _, s, vt = np.linalg.svd(centred, full_matrices=False)
    return vt[-1], float(s[-1] / math.sqrt(points.shape[0]))


def _cross_matrices(v: Array) -> Array:
    """[v]× for each row of v (n, 3): [v]× w = v × w."""
    out = np.zeros((v.shape[0], 3, 3))
    out[:, 0, 1], out[:, 0, 2] = -v[:, 2], v[:, 1]
    out[:, 1, 0], out[:, 1, 2] = v[:, 2], -v[:, 0]
    out[:, 2, 0], out[:, 2, 1] = -v[:, 1], v[:, 0]
    return out


AnyReference: TypeAlias = Reference
"""Any kind of reference a group of records measures (`ReferenceRecords.reference`): the protocol, so that a new
kind (a cylinder, an interferometer's line: a file of its own) is no edit here."""


@dataclass(frozen=True)
class ReferenceRecords:
    """The records measured against one reference: joints (n, n_joints, internal units), each record's
    measured value (an anchor's distance, mm; a tracker's position (n, 3), mm; a camera's point and pixel (n, 7),
    `models.measurements.camera`; unused by points and planes) and its σ (in the reference's `sigma_unit`: mm,
    a camera's px; None: the noise model's position σ, for references in mm); `index` where each record stands
    in the campaign as the user gave it (None: 0, 1, … within this group), so that a record is named as the
    user knows it."""

    reference: AnyReference
    joints: Array
    values: Array
    sigma_mm: Array | None = None
    index: NDArray[np.intp] | None = None

    @property
    def size(self) -> int:
        return int(self.joints.shape[0])

    @property
    def positions(self) -> NDArray[np.intp]:
        """Each record's place in the campaign as given."""
        return np.arange(self.size, dtype=np.intp) if self.index is None else self.index

    def subset(self, index: NDArray[np.intp]) -> ReferenceRecords:
        sigma = None if self.sigma_mm is None else self.sigma_mm[index]
        return ReferenceRecords(self.reference, self.joints[index], self.values[index], sigma, self.positions[index])

    def with_reference(self, reference: AnyReference) -> ReferenceRecords:
        return replace(self, reference=reference)

    def check(self) -> None:
        """Enough records to determine the reference at all; a 4xx naming it otherwise."""
        ref, needed = self.reference, self.reference.minimum_records
        if self.size < needed:
            raise TooFewMeasurements(
                f"{ref.traits.kind} {ref.name!r} has {self.size} records: at least {needed} are needed to determine "
                f"its {len(ref.unknowns)} unknowns; measure {needed - self.size} more",
                got=self.size,
                needed=needed,
                missing=needed - self.size,
                kind=ref.traits.kind,
            )
        expected = (self.size,) if ref.traits.value_columns <= 1 else (self.size, ref.traits.value_columns)
        if ref.traits.value_columns and self.values.shape != expected:
            raise InvalidInput(
                f"{ref.traits.kind} {ref.name!r}: expected measured values of shape {expected}, got "
                f"{self.values.shape}",
                field="measurements",
            )
        if self.sigma_mm is None and ref.traits.sigma_unit != "mm":
            raise InvalidInput(
                f"{ref.traits.kind} {ref.name!r}: give each record's σ in {ref.traits.sigma_unit} (the noise model's "
                "σ is in mm)",
                field="sigma_mm",
            )
