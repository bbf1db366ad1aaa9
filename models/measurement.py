"""The kinds of measurement, named once: what a campaign's records are (their models: `models.measurements`)."""

from __future__ import annotations

from enum import StrEnum

from models.errors import InvalidInput


class MeasurementKind(StrEnum):
    POSE = "pose"
    """Position and orientation (e.g. a laser tracker with a 6-DOF probe): six equations per pose."""
    POSITION = "position"
    """Position only (e.g. one reflector): three equations per pose, the orientation is free."""

    @property
    def rows(self) -> int:
        """Measured coordinates per pose (the kind's model says: `models.measurements`)."""
        from models.measurements import MEASUREMENTS  # noqa: PLC0415  (the models import this enum)

        return MEASUREMENTS[self].rows

    @property
    def position_only(self) -> bool:
        return self is MeasurementKind.POSITION

    @property
    def label(self) -> str:
        """For messages: "full-pose" or "position-only"."""
        from models.measurements import MEASUREMENTS  # noqa: PLC0415  (the models import this enum)

        return MEASUREMENTS[self].label

    @staticmethod
    def parse(value: object, *, field: str = "measurement") -> MeasurementKind:
        """The kind a user named; InvalidInput naming `field` and the kinds there are otherwise."""
        allowed = [kind.value for kind in MeasurementKind]
        if value not in allowed:
            raise InvalidInput(
                f"{field} must be one of {allowed}, got {value!r}", field=field, value=str(value), allowed=allowed
            )
        return MeasurementKind(str(value))

    @staticmethod
    def of(value: MeasurementKind | str | bool) -> MeasurementKind:
        """A kind from a kind, its value ("pose", "position"), or the older `position_only` flag."""
        if isinstance(value, bool):
            return MeasurementKind.POSITION if value else MeasurementKind.POSE
        return MeasurementKind(value)
