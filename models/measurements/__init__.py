"""The kinds of measurement (`models.measurements.base.Measurement`), one registry entry each.

A new instrument (a ballbar, a probe, a camera) is a module here implementing `Measurement`, its member in
`models.measurement.MeasurementKind` and its entry in `MEASUREMENTS`.
"""

from models.measurement import MeasurementKind
from models.measurements.base import Index, Measurement, ModelBatch
from models.measurements.tcp import TcpMeasurement

MEASUREMENTS: dict[MeasurementKind, Measurement] = {
    MeasurementKind.POSE: TcpMeasurement.POSE,
    MeasurementKind.POSITION: TcpMeasurement.POSITION,
}
"""Each kind's model, by the kind a campaign's records are."""


def measurement(kind: MeasurementKind | str | bool) -> Measurement:
    """The model of a kind (or of its name, or of the older `position_only` flag)."""
    return MEASUREMENTS[MeasurementKind.of(kind)]


__all__ = ["MEASUREMENTS", "Index", "Measurement", "MeasurementKind", "ModelBatch", "TcpMeasurement", "measurement"]
