"""The stages a robot is made of (robots.md): each kind one module, read by the kind its document names.

A new kind of stage (a delta, a second kind of parallel mechanism) is a new module here implementing `Stage`,
its reader registered in `READERS`, and its variant in the service's structure schema.
"""

from models.stages.base import Placement, Section, Stage, StageReader
from models.stages.hexapod import HexapodStage, read_hexapod
from models.stages.serial import SerialStage, read_serial

READERS: dict[str, StageReader] = {SerialStage.kind: read_serial, HexapodStage.kind: read_hexapod}
"""Each stage kind's document reader, by the `kind` of its document."""

__all__ = ["READERS", "HexapodStage", "Placement", "Section", "SerialStage", "Stage", "StageReader"]
