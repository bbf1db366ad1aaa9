"""What an instrument measures: the whole TCP pose, or its position only."""

from __future__ import annotations

from enum import StrEnum


class MeasurementKind(StrEnum):
    POSE = "pose"
    """Position and orientation (e.g. a laser tracker with a 6-DOF probe): six equations per pose."""
    POSITION = "position"
    """Position only (e.g. one reflector): three equations per pose, the orientation is free."""

    @property
    def rows(self) -> int:
        """Measured coordinates per pose."""
        return 3 if self is MeasurementKind.POSITION else 6

    @property
    def position_only(self) -> bool:
        return self is MeasurementKind.POSITION

    @property
    def label(self) -> str:
        """For messages: "full-pose" or "position-only"."""
        return "position-only" if self is MeasurementKind.POSITION else "full-pose"

    @staticmethod
    def of(value: MeasurementKind | str | bool) -> MeasurementKind:
        """A kind from a kind, its value ("pose", "position"), or the older `position_only` flag."""
        if isinstance(value, bool):
            return MeasurementKind.POSITION if value else MeasurementKind.POSE
        return MeasurementKind(value)
