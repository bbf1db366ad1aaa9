"""The description document of `shared/spec/robots.md`: a robot of any structure, read and written.

`description_from_document` validates a document (JSON-shaped: mm and degrees, quaternions `[w, x, y, z]`)
and builds the frozen `RobotDescription`; every rule of robots.md that a document breaks raises
`InvalidInput` naming the field by its path (`stages[1].links[2].range`). `description_document` writes the
document back, with the nominal values of the description or with a calibrated parameter vector; the result
is accepted by `description_from_document` again.

Nothing of a document reaches generated code: the structure key (`RobotDescription.structure`) is made of
enumerations and counts, and the numbers are inputs of the compiled Functions.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from models._types import IDENTITY, Array
from models.description.robot import RobotDescription
from models.errors import InvalidInput
from models.stages import READERS, Stage
from models.stages.document import mapping, pose, pose_document

Document = dict[str, Any]

MAX_LINKS = 64
"""More links than any real robot; a bound on what one request can make the service build."""
MAX_PARALLEL_STAGES = 1
"""robots.md: at most one hexapod stage. The models compose any number (`models.stages`); the document keeps
the contract's limit until the service's joint names and schemas carry several."""

_TOP_KEYS = {"base", "tool", "stages"}


# ---------------------------------------------------------------------------------------------- reading
def description_from_document(document: object, *, name: str = "custom") -> RobotDescription:
    """The validated description of a robots.md document (see the module docstring)."""
    doc = mapping(document, "structure", _TOP_KEYS)
    raw_stages = doc.get("stages")
    if not isinstance(raw_stages, list) or not raw_stages:
        raise InvalidInput("a structure needs a non-empty list of stages", field="stages")
    stages: list[Stage] = []
    n_links = n_parallel = 0
    for i, raw in enumerate(raw_stages):
        where = f"stages[{i}]"
        kind = raw.get("kind") if isinstance(raw, Mapping) else None
        reader = READERS.get(kind) if isinstance(kind, str) else None
        if reader is None or not isinstance(raw, Mapping):
            if not isinstance(raw, Mapping):
                raise InvalidInput("a stage must be an object", field=where)
            raise InvalidInput(
                f"unknown stage kind {kind!r}", field=f"{where}.kind", value=str(kind), allowed=list(READERS)
            )
        stage = reader(raw, where)
        n_links += len(stage.dh_links)
        if n_links > MAX_LINKS:
            raise InvalidInput(f"a structure has at most {MAX_LINKS} links", field=f"{where}.links")
        if stage.n_unknowns:
            n_parallel += 1
            if n_parallel > MAX_PARALLEL_STAGES:
                raise InvalidInput(f"a structure has at most one {stage.kind} stage", field=f"{where}.kind")
        stages.append(stage)
    if not any(stage.moves for stage in stages):
        raise InvalidInput("a structure needs at least one moving joint (or a hexapod stage)", field="stages")
    base = pose(doc["base"], "base") if doc.get("base") is not None else IDENTITY
    tool = pose(doc["tool"], "tool") if doc.get("tool") is not None else IDENTITY
    return RobotDescription(name=name, stages=tuple(stages), base=base, tool=tool)


# ---------------------------------------------------------------------------------------------- writing
def description_document(desc: RobotDescription, params: Array | None = None) -> Document:
    """The robots.md document of `desc`, with the values of `params` (internal units; default nominal)."""
    theta = desc.parameters.nominal if params is None else desc.parameters.vector(params)
    return {
        "base": pose_document(theta[desc.slices["base"]]),
        "tool": pose_document(theta[desc.slices["tool"]]),
        "stages": [stage.document(theta[at.params]) for stage, at in zip(desc.stages, desc.placements, strict=True)],
    }
