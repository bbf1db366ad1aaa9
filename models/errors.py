"""Domain errors: each carries the data a user needs to fix the input.

The service maps each class to an HTTP problem in one table; library users
catch the same classes. Keep this tree small and every field JSON-friendly.
"""

from __future__ import annotations

from typing import Any


class CalibrationError(Exception):
    """Root of every domain error raised by this project."""

    def __init__(self, detail: str, **data: Any) -> None:
        super().__init__(detail)
        self.detail = detail
        self.data: dict[str, Any] = data


class InvalidInput(CalibrationError):
    """The caller's data cannot be used as given."""


class WrongShape(InvalidInput):
    """An array has the wrong number of elements (e.g. a joint vector that is not ten numbers)."""


class NonFiniteValue(InvalidInput):
    """A NaN or infinite number."""


class JointOutOfRange(InvalidInput):
    """A joint or leg length outside its range."""


class UnreachablePose(InvalidInput):
    """A hexapod that cannot assemble, a pose outside the workspace or near a singularity."""


class InvalidQuaternion(InvalidInput):
    """A quaternion far from unit norm."""


class TooFewMeasurements(InvalidInput):
    """Not enough data to identify what was asked for."""


class UnknownParameter(InvalidInput):
    """A parameter name or group that the robot does not have."""


class NotIdentifiable(CalibrationError):
    """The data cannot determine the requested parameters."""


class SolverFailed(CalibrationError):
    """A numerical solver did not reach a usable solution."""


class InconsistentData(CalibrationError):
    """Data that cannot come from this robot (residuals far beyond the stated noise)."""
