"""A mount: the fixed place of a branch on its parent (an arm's shoulder on a torso, a positioner on the floor).

A serial stage's first link is written from its start frame's x axis along the common normal to its axis; two
arms on one torso want two different common normals from the same torso frame, which one frame cannot give.
A mount is the general rigid transform instead, six numbers like the base and the tool (a translation in mm and
a rotation vector in rad), so each branch of a tree starts wherever it is. It has no joint, so its six numbers
and the branch's first link overlap (the identifiability analysis picks which of them are estimated, as it does
for a chain's base and first link).

A stage of the `models.stages.base.Stage` protocol that no robots.md document names: a tree builds it
(`models.tree`), the service's single-chain documents never hold one.
"""

# ruff: noqa: ARG002  (a stage implements its whole protocol, whatever it uses of it: as models/stages/*.py)

from __future__ import annotations

from collections.abc import Hashable
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from models._types import Array, Pose6
from models.description.parameters import Kind, ParameterScales, ParameterSpec
from models.description.serial_chain import DHLink
from models.stages.base import Section, WithoutClosure
from models.stages.document import pose_document
from models.transforms import Sym, homogeneous, rotvec_to_matrix

MOUNT_FIELDS = ("x", "y", "z", "rx", "ry", "rz")


@dataclass(frozen=True)
class MountStage(WithoutClosure):
    """The fixed transform parent frame <- branch frame 0: (x, y, z mm, rotation vector rad)."""

    pose: Pose6

    kind: ClassVar[str] = "mount"
    section: ClassVar[Section] = Section.LINKS
    group: ClassVar[str] = "mount"
    classic_group: ClassVar[str] = "mount"

    @property
    def n_joints(self) -> int:
        return 0

    @property
    def n_params(self) -> int:
        return 6

    @property
    def n_items(self) -> int:
        """It numbers no link: the links after it keep the numbers they would have without it."""
        return 0

    @property
    def token(self) -> Hashable:
        return "mount"

    @property
    def moves(self) -> bool:
        return False

    @property
    def dh_links(self) -> tuple[DHLink, ...]:
        return ()

    def joint_names(self, first: int) -> tuple[str, ...]:
        return ()

    def joint_kinds(self) -> tuple[Kind, ...]:
        return ()

    def joint_limits(self) -> tuple[Array, Array]:
        return np.zeros(0), np.zeros(0)

    def parameter_specs(self, first: int, scales: ParameterScales, group: str) -> list[ParameterSpec]:
        # A mount is placed as well as a base (a torso's shoulder flange, a positioner bolted to the floor).
        return [
            ParameterSpec(
                name=f"mount.{field}",
                group=group,
                kind=Kind.LENGTH if k < 3 else Kind.ANGLE,
                nominal=float(self.pose[k]),
                scale=scales.base_length if k < 3 else scales.base_angle,
            )
            for k, field in enumerate(MOUNT_FIELDS)
        ]

    def transform(self, q: Sym, x: Sym, p: Sym) -> Sym:
        return homogeneous(rotvec_to_matrix(p[3:6]), p[0:3])

    def usable(self, q: Array, x: Array, p: Array) -> Array:
        return np.ones(q.shape[0], dtype=bool)

    def document(self, p: Array) -> dict[str, Any]:
        return {"kind": self.kind, "pose": pose_document(np.asarray(p, dtype=float))}
