"""URDF trees: a URDF read with the tips a user names (`tip_links`: the two hands of a dual-arm or a humanoid).

The paths from `base_link` to each tip are cut at the links where they part (and at tips that lie on another
tip's path): each piece between two such links is a branch. A piece is read by the chain importer,
`models.formats.urdf.document_from_urdf(urdf, start, end)`, whose FK equals the URDF's: its MDH links on the joints'
axis lines, its `base` (start link <- its frame 0) and its `tool` (its last frame -> end link). The pieces then
compose exactly: the tree's base is the first piece's base, a branch's mount is its parent's tool composed with
its own base, a tip's tool is its piece's. A piece without a moving joint (a fixed torso below two arms) adds
no branch: the pieces below it start at its start link, their mounts carrying the fixed transform.

The common prefix of every tip's path is so the trunk (a humanoid's torso joints, a dual-arm's waist); joints
keep their URDF names.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from models._types import IDENTITY, Array, Pose6
from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.urdf import document_from_urdf, load_urdf, origin_mm, urdf_joint_names
from models.formats.urdf_tree import tree_parents
from models.stages.document import pose
from models.transforms import matrix_to_rotvec_np, rotvec_to_matrix_np
from models.tree.tree import Branch, RobotTree


def _path(parents: dict[str, Any], base_link: str, tip: str, field: str) -> list[str]:
    """The links from `base_link` down to `tip`, both included."""
    links, at = [tip], tip
    while at != base_link:
        joint = parents.get(at)
        if joint is None:
            raise InvalidInput(
                f"{tip!r} is not below {base_link!r} in the URDF's tree: choose tips below the base link",
                field=field,
                value=tip,
            )
        at = joint.parent
        links.append(at)
    return links[::-1]


def _pieces(paths: dict[str, list[str]], base_link: str) -> list[tuple[str, str]]:
    """(start link, end link) of every piece, parents before children: paths cut where they part and at tips."""
    following: dict[str, set[str]] = {}
    for path in paths.values():
        for here, after in itertools.pairwise(path):
            following.setdefault(here, set()).add(after)
    cuts = {base_link, *paths} | {link for link, after in following.items() if len(after) > 1}
    pieces: list[tuple[str, str]] = []
    for path in paths.values():
        start = path[0]
        for link in path[1:]:
            if link in cuts:
                if (start, link) not in pieces:
                    pieces.append((start, link))
                start = link
    return pieces


def _matrix(p: Pose6) -> Array:
    t = np.eye(4)
    t[:3, :3] = rotvec_to_matrix_np(np.asarray(p[3:], dtype=float))
    t[:3, 3] = p[:3]
    return t


def _pose6(t: Array) -> Pose6:
    rv = matrix_to_rotvec_np(t[:3, :3])
    return (float(t[0, 3]), float(t[1, 3]), float(t[2, 3]), float(rv[0]), float(rv[1]), float(rv[2]))


def _fixed(parents: dict[str, Any], start: str, end: str) -> Array:
    """start link <- end link (mm) through the fixed joints between them."""
    t, at = np.eye(4), end
    while at != start:
        t = origin_mm(parents[at]) @ t
        at = parents[at].parent
    return t


def tree_from_urdf(urdf: str, base_link: str, tip_links: Sequence[str], *, name: str = "urdf-tree") -> RobotTree:
    """The tree of the URDF's chains from `base_link` to each of `tip_links` (see the module docstring).
    Branches are named after their end links; a tip's tool is the tip link's frame."""
    if not tip_links or len(set(tip_links)) != len(tip_links):
        raise InvalidInput("name one or more different tip links", field="tip_links")
    parents = tree_parents(load_urdf(urdf))
    for k, tip in enumerate(tip_links):
        if tip not in parents and tip != base_link:
            raise InvalidInput(f"the URDF has no link {tip!r} below a joint", field=f"tip_links[{k}]", value=tip)
    paths = {tip: _path(parents, base_link, tip, f"tip_links[{k}]") for k, tip in enumerate(tip_links)}
    branches: list[Branch] = []
    # Each piece's end link -> (the branch ending there, None at the base; base-or-end frame <- that link).
    ends: dict[str, tuple[str | None, Array]] = {base_link: (None, np.eye(4))}
    base: Array | None = None
    for start, end in _pieces(paths, base_link):
        parent, above = ends[start]
        if not any(j.type != "fixed" for j in _joints(parents, start, end)):
            if end in paths:
                raise InvalidInput(
                    f"tip link {end!r} has no moving joint after {start!r}: choose a tip below a moving joint",
                    field="tip_links",
                    value=end,
                )
            ends[end] = (parent, above @ _fixed(parents, start, end))
            continue
        doc = document_from_urdf(urdf, start, end)
        frame0, tool = _matrix(pose(doc["base"], "base")), _matrix(pose(doc["tool"], "tool"))
        mount: Pose6 | None = None
        if not branches and parent is None and start == base_link:
            base = frame0  # the first chain from the base link: its frame 0 is the tree's base, as a chain's
        else:
            # Below another branch's end, or a second chain from the base: placed by a mount in that frame.
            mount = _pose6((np.linalg.inv(base) if parent is None and base is not None else np.eye(4)) @ above @ frame0)
        stages = description_from_document({"stages": doc["stages"]}).stages
        tip_tool = _pose6(tool) if end in paths else None
        names = urdf_joint_names(urdf, start, end)
        branches.append(Branch(end, stages, parent=parent, mount=mount, tool=tip_tool, joint_names=names))
        ends[end] = (end, tool)
    return RobotTree(name, tuple(branches), base=IDENTITY if base is None else _pose6(base))


def _joints(parents: dict[str, Any], start: str, end: str) -> list[Any]:
    out, at = [], end
    while at != start:
        out.append(parents[at])
        at = parents[at].parent
    return out
