"""Domain errors: each carries the data a user needs to fix the input.

The service maps each class to an HTTP problem in one table; library users
catch the same classes. Every class declares its fields (keyword-only,
JSON-safe); `.data` is the dictionary of them, the problem's extension
members, so a class has the same members wherever it is raised.

    CalibrationError(detail)
    ├── InvalidInput(field, reason, value, allowed, min, max)    the caller's data cannot be used
    │   ├── WrongShape(field, expected, got)
    │   ├── NonFiniteValue(field, pose, joint)
    │   ├── JointOutOfRange(pose, joint, value, min, max, unit, count)
    │   ├── UnreachablePose(pose, reason, count, draw)
    │   ├── InvalidQuaternion(pose, norm, count)
    │   ├── TooFewMeasurements(got, needed, missing, kind)
    │   ├── UnknownParameter(name)
    │   ├── TargetUnreachable(field, target_mm, reachable_mm, candidates)   pose design's target mode
    │   ├── PriorMismatch(expected, got)       a prior of another robot model (parameter counts, fleet keys)
    │   └── FleetTooSmall(units, needed)       too few calibrated units for a fleet's population
    ├── NotIdentifiable()                      the data determine none of the requested parameters
    ├── SolverFailed(solver, status, iterations)
    └── InconsistentData(rms_sigma, limit_sigma)

`field` names the input to blame (an argument or option); `pose` is always
the 0-based index of the pose (record, target) in the caller's batch; values
are in boundary units where a `unit` says so.
A field is None where it does not apply, and `.data` leaves it out.
`SolverFailed` and `InconsistentData` are raised by `identify(..., strict=True)`;
without `strict` the same failures come back as a failed result.
"""

from __future__ import annotations

from typing import Any, ClassVar


class CalibrationError(Exception):
    """Root of every domain error raised by this project."""

    fields: ClassVar[tuple[str, ...]] = ()
    """The names of the keyword-only fields of the class, in `.data` order."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail

    @property
    def data(self) -> dict[str, Any]:
        """The fields that have a value, as a JSON-safe dictionary (a problem document's extension members).

        A field left at None (not known where the error was raised) is absent rather than null.
        """
        values = ((name, getattr(self, name)) for name in self.fields)
        return {name: value for name, value in values if value is not None}


class InvalidInput(CalibrationError):
    """The caller's data cannot be used as given."""

    fields: ClassVar[tuple[str, ...]] = ("field", "reason", "value", "allowed", "min", "max")

    def __init__(
        self,
        detail: str,
        *,
        field: str | None = None,
        reason: str | None = None,
        value: str | float | None = None,
        allowed: list[str] | None = None,
        min: float | None = None,
        max: float | None = None,
    ) -> None:
        super().__init__(detail)
        self.field = field
        """Which input (an option or argument name), when one is to blame."""
        self.reason = reason
        """A machine-readable cause, where the detail alone would have to be parsed."""
        self.value = value
        self.allowed = allowed
        """The values `field` may take, when they are a list."""
        self.min = min
        self.max = max


class WrongShape(InvalidInput):
    """An array has the wrong number of elements (e.g. a joint vector that is not ten numbers)."""

    fields = ("field", "expected", "got")

    def __init__(
        self, detail: str, *, field: str | None = None, expected: list[int] | None = None, got: list[int] | None = None
    ) -> None:
        super().__init__(detail, field=field)
        self.expected = expected
        """The expected shape (-1: any length)."""
        self.got = got


class NonFiniteValue(InvalidInput):
    """A NaN or infinite number."""

    fields = ("field", "pose", "joint")

    def __init__(
        self, detail: str, *, field: str | None = None, pose: int | None = None, joint: str | None = None
    ) -> None:
        super().__init__(detail, field=field)
        self.pose = pose
        self.joint = joint


class JointOutOfRange(InvalidInput):
    """A joint or leg length outside its range (the first one; `count` poses have one)."""

    fields = ("pose", "joint", "value", "min", "max", "unit", "count")

    def __init__(
        self,
        detail: str,
        *,
        pose: int,
        joint: str,
        value: float,
        min: float,
        max: float,
        unit: str,
        count: int = 1,
    ) -> None:
        super().__init__(detail, field="joints", value=value, min=min, max=max)
        self.pose = pose
        self.joint = joint
        self.unit = unit
        self.count = count


class UnreachablePose(InvalidInput):
    """A hexapod that cannot assemble, a pose outside the workspace or near a singularity."""

    fields = ("pose", "reason", "count", "draw")

    def __init__(self, detail: str, *, pose: int, reason: str, count: int = 1, draw: int | None = None) -> None:
        super().__init__(detail, field="joints")
        self.pose = pose
        self.reason = reason
        """"no_assembly", "outside_workspace" or "near_singularity"."""
        self.count = count
        self.draw = draw
        """The Monte Carlo draw of a tolerance study that broke the assembly (None: not a study)."""


class InvalidQuaternion(InvalidInput):
    """A quaternion far from unit norm."""

    fields = ("pose", "norm", "count")

    def __init__(self, detail: str, *, pose: int | None = None, norm: float, count: int = 1) -> None:
        super().__init__(detail, field="quaternions")
        self.pose = pose
        self.norm = norm
        self.count = count


class TooFewMeasurements(InvalidInput):
    """Not enough data to identify what was asked for."""

    fields = ("got", "needed", "missing", "kind")

    def __init__(self, detail: str, *, got: int, needed: int, missing: int, kind: str) -> None:
        super().__init__(detail, field="measurements")
        self.got = got
        self.needed = needed
        self.missing = missing
        self.kind = kind
        """"pose" or "position" (`MeasurementKind`)."""


class UnknownParameter(InvalidInput):
    """A parameter name or group that the robot does not have."""

    fields = ("name",)

    def __init__(self, detail: str, *, name: str) -> None:
        super().__init__(detail, field="estimate")
        self.name = name


class TargetUnreachable(InvalidInput):
    """No number of poses up to the candidate count reaches the requested accuracy (pose design's target mode)."""

    fields = ("field", "target_mm", "reachable_mm", "candidates")

    def __init__(self, detail: str, *, field: str, target_mm: float, reachable_mm: float, candidates: int) -> None:
        super().__init__(detail, field=field)
        self.target_mm = target_mm
        self.reachable_mm = reachable_mm
        """The best predicted error any selection of the candidates (or the best design found) reaches."""
        self.candidates = candidates


class PriorMismatch(InvalidInput):
    """A prior of another robot model: its parameters are not this robot's."""

    fields = ("expected", "got")

    def __init__(self, detail: str, *, expected: int | str, got: int | str) -> None:
        super().__init__(detail, field="prior", reason="structure")
        self.expected = expected
        """This robot's: its parameter count, or (over HTTP) its fleet's key."""
        self.got = got
        """The prior's: its parameter count, or the fleet key asked for."""


class FleetTooSmall(InvalidInput):
    """Too few calibrated units of a robot model to estimate its population (fleet priors)."""

    fields = ("units", "needed")

    def __init__(self, detail: str, *, units: int, needed: int) -> None:
        super().__init__(detail, field="prior")
        self.units = units
        """Calibrated units the fleet has (the unit being calibrated not counted)."""
        self.needed = needed


class NotIdentifiable(CalibrationError):
    """The data cannot determine the requested parameters."""


class SolverFailed(CalibrationError):
    """A numerical solver did not reach a usable solution."""

    fields = ("solver", "status", "iterations")

    def __init__(self, detail: str, *, solver: str, status: str, iterations: int) -> None:
        super().__init__(detail)
        self.solver = solver
        self.status = status
        self.iterations = iterations


class InconsistentData(CalibrationError):
    """Data that cannot come from this robot (residuals far beyond the stated noise, or where the model is
    undefined)."""

    fields = ("rms_sigma", "limit_sigma")

    def __init__(self, detail: str, *, rms_sigma: float | None, limit_sigma: float) -> None:
        super().__init__(detail)
        self.rms_sigma = rms_sigma
        """RMS standardised residual after the fit; None where the model is undefined at the solution."""
        self.limit_sigma = limit_sigma
