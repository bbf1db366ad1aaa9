"""URDF text for the tests' robots, written from a table of joints (one row a joint, its numbers as the support
package writes them) instead of the same XML block once a joint."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

LINKS_PER_LINE = 4
X_AXIS, Y_AXIS, Z_AXIS = "1 0 0", "0 1 0", "0 0 1"


@dataclass(frozen=True)
class UrdfJoint:
    """One `<joint>`: its numbers are text, written as given, so that a table keeps the package's own digits."""

    name: str
    kind: str
    """"revolute", "continuous", "prismatic" or "fixed"."""
    parent: str
    child: str
    xyz: str = "0 0 0"
    axis: str | None = None
    """None: no `<axis>` element (a fixed joint's)."""
    limit: tuple[str, str, str, str] | None = None
    """(lower, upper, effort, velocity); None: no `<limit>` element."""
    rpy: str = "0 0 0"

    def xml(self) -> str:
        text = f'  <joint name="{self.name}" type="{self.kind}"><parent link="{self.parent}"/>'
        text += f'<child link="{self.child}"/>\n    <origin xyz="{self.xyz}" rpy="{self.rpy}"/>'
        if self.axis is not None:
            text += f'<axis xyz="{self.axis}"/>'
        if self.limit is not None:
            lower, upper, effort, velocity = self.limit
            text += f'\n    <limit lower="{lower}" upper="{upper}" effort="{effort}" velocity="{velocity}"/>'
        return text + "</joint>\n"


def urdf_robot(name: str, joints: Sequence[UrdfJoint]) -> str:
    """A `<robot>` of `joints` and the links they name (in the order they first appear), without meshes."""
    links = list(dict.fromkeys(link for joint in joints for link in (joint.parent, joint.child)))
    rows = [links[k : k + LINKS_PER_LINE] for k in range(0, len(links), LINKS_PER_LINE)]
    link_lines = "".join("  " + "".join(f'<link name="{link}"/>' for link in row) + "\n" for row in rows)
    return f'<?xml version="1.0"?>\n<robot name="{name}">\n{link_lines}{"".join(j.xml() for j in joints)}</robot>\n'
