"""The checks a URDF passes before its chain is read (models.formats.urdf): a bounded size, one tree, a serial chain.

Each check is linear in the document and names the fix. Before them, a URDF whose joints formed a cycle (two
joints l1 -> l2 -> l1, or a self-loop) made the walk from the tip towards the base run forever, its path growing
until the process was killed (issue 31); `tests/models/test_urdf_hostile.py` makes each attack and
`tests/models/test_urdf_fuzz.py` draws random joint graphs against an independent reading.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from models.errors import InvalidInput

MAX_LINKS = 1000
"""Links (and joints) a URDF may have. Real robots have tens (a PR2 about 90, a humanoid about 100); the bound
keeps a hostile document's reading short (10 000 links parse in ~0.4 s here), and it is checked on the raw text
before any parsing."""
SERIAL_JOINTS = ("revolute", "continuous", "prismatic", "fixed")


def check_size(urdf: str) -> None:
    """Refuse, before the XML parser sees it, a document with more than MAX_LINKS links. `str.count` is linear
    and C-speed, and an over-count (a `<link` in a comment) only errs on the side of refusing a document
    that is close to the bound anyway. Joints are bounded at twice that: `<transmission>` repeats their names."""
    for tag, bound in (("link", MAX_LINKS), ("joint", 2 * MAX_LINKS)):
        found = urdf.count(f"<{tag}")
        if found > bound:
            raise InvalidInput(
                f"the URDF has {found} <{tag}> elements; at most {bound} are accepted (a robot arm has tens): "
                "send the URDF of the robot alone",
                field="urdf",
                reason="too_large",
                value=found,
                max=bound,
            )


def _unique(kind: str, names: list[str]) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise InvalidInput(
                f"the URDF has two {kind}s named {name!r}: {kind} names must be unique; rename one",
                field="urdf",
                value=name,
            )
        seen.add(name)


def _check_joint(joint: Any, defined: set[str], parent_of: dict[str, Any]) -> None:
    """A joint between two defined, different links, whose child has no other parent."""
    for role, link in (("parent", joint.parent), ("child", joint.child)):
        if link not in defined:
            raise InvalidInput(
                f"joint {joint.name!r} names {role} link {link!r}, which the URDF does not define: "
                f"add <link name={link!r}/> or correct the joint",
                field="urdf",
                value=link,
            )
    if joint.parent == joint.child:
        raise InvalidInput(
            f"joint {joint.name!r} connects link {joint.child!r} to itself: a joint's parent and child must "
            "differ; remove the joint",
            field="urdf",
            value=joint.name,
        )
    if joint.child in parent_of:
        raise InvalidInput(
            f"link {joint.child!r} is the child of two joints, {parent_of[joint.child].name!r} and "
            f"{joint.name!r}: in a URDF each link has one parent joint (a closed chain cannot be described); "
            "remove one of them",
            field="urdf",
            value=joint.child,
        )


def _cycle(start: str, parent_of: dict[str, Any]) -> list[str]:
    """The joints of the cycle above `start`, base to tip. Every link has at most one parent, so what no root
    reaches lies on (or hangs from) a cycle: its parents repeat within len(parent_of) steps."""
    at, seen = start, set()
    while at not in seen:
        seen.add(at)
        at = parent_of[at].parent
    cycle, link = [], at
    while True:
        cycle.append(parent_of[link].name)
        link = parent_of[link].parent
        if link == at:
            return cycle[::-1]


def tree_parents(robot: Any) -> dict[str, Any]:
    """Child link -> its joint, once the links and joints are checked to form one tree (linear in their count).

    A URDF is a tree: unique names, every joint between two defined links, each link the child of at most one
    joint, one root, no cycle. Without these checks the walk from the tip towards the base of a cycle
    (l1 -> l2 -> l1) never ended and grew memory until the process was killed."""
    links = [link.name for link in robot.links]
    if len(links) > MAX_LINKS or len(robot.joints) > MAX_LINKS:
        raise InvalidInput(
            f"the URDF has {len(links)} links and {len(robot.joints)} joints; at most {MAX_LINKS} of each are "
            "accepted: send the URDF of the robot alone",
            field="urdf",
            reason="too_large",
            max=MAX_LINKS,
        )
    _unique("link", links)
    _unique("joint", [joint.name for joint in robot.joints])
    defined = set(links)
    parent_of: dict[str, Any] = {}
    children: dict[str, list[str]] = {}
    for joint in robot.joints:
        _check_joint(joint, defined, parent_of)
        parent_of[joint.child] = joint
        children.setdefault(joint.parent, []).append(joint.child)
    roots = [link for link in links if link not in parent_of]
    reached = set(roots)
    frontier = list(roots)
    while frontier:
        for child in children.get(frontier.pop(), ()):
            reached.add(child)
            frontier.append(child)
    if len(reached) < len(links):
        cycle = _cycle(next(link for link in links if link not in reached), parent_of)
        raise InvalidInput(
            f"the joints {', '.join(repr(j) for j in cycle)} form a cycle: a URDF is a tree; "
            "remove one joint of the cycle",
            field="urdf",
            reason="cycle",
            value=", ".join(sorted(cycle)),
        )
    if len(roots) > 1:
        shown = ", ".join(repr(r) for r in roots[:5]) + (", …" if len(roots) > 5 else "")
        raise InvalidInput(
            f"the URDF has {len(roots)} root links ({shown}): a URDF is one tree; connect them with fixed joints "
            "or remove the unused links",
            field="urdf",
            reason="several_roots",
            value=", ".join(roots[:5]),
        )
    return parent_of


def check_serial(joint: Any) -> None:
    """A joint of the chain: a type a serial stage has, independent (no mimic), finite numbers."""
    if joint.type not in SERIAL_JOINTS:
        raise InvalidInput(
            f"joint {joint.name!r} is {joint.type}: a serial stage has revolute, continuous, prismatic and "
            "fixed joints; make it fixed (its origin becomes geometry) or choose a base_link below it",
            field="urdf",
            value=str(joint.type),
            allowed=list(SERIAL_JOINTS),
        )
    if joint.mimic is not None and joint.type != "fixed":
        raise InvalidInput(
            f"joint {joint.name!r} mimics joint {joint.mimic.joint!r}: every moving joint of the chain is an "
            "independent coordinate here; remove its <mimic> or make it fixed",
            field="urdf",
            value=joint.name,
        )
    if joint.type != "fixed" and joint.axis is not None:
        axis = np.asarray(joint.axis, dtype=float)
        # The largest component, not the norm: the norm of `1e308 0 0` overflows (a warning, an error in tests).
        if not (np.all(np.isfinite(axis)) and np.abs(axis).max() > 1e-9):
            raise InvalidInput(
                f"joint {joint.name!r} has axis {axis.tolist()}: give a finite, non-zero <axis xyz>",
                field="urdf",
                value=joint.name,
            )
    if joint.origin is not None and not np.all(np.isfinite(np.asarray(joint.origin, dtype=float))):
        raise InvalidInput(f"joint {joint.name!r} has a non-finite <origin>: give finite xyz and rpy", field="urdf")
