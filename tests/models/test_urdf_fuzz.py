"""Property-based fuzz of the robot-description readers (issue 31): whatever the document, an answer or an
InvalidInput, never another exception, a hang or a second's work.

The URDF's joint graphs are drawn at random (cycles, self-loops, links with two parents, several roots, undefined
links, duplicate names, every joint type, mimic joints, base and tip anywhere) and the reader's verdict is
compared with an independent one: a top-down search from the root (the reader walks bottom-up from the tip).
`make test` draws IWR_URDF_FUZZ_EXAMPLES (default 60) per property, `make fuzz` 2 000."""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from datetime import timedelta
from typing import Any

import pytest
import yourdfpy  # noqa: F401  (imported here so that its first import is not inside an example's deadline)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.urdf import document_from_urdf
from tests.models.test_urdf_hostile import joint, urdf

EXAMPLES = int(os.environ.get("IWR_URDF_FUZZ_EXAMPLES", "60"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=timedelta(seconds=1),  # the bound on any refusal
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=EXAMPLES <= 60,  # reproducible in `make test`; `make fuzz` explores
)
KINDS = ["revolute", "continuous", "prismatic", "fixed", "floating", "planar"]
SERIAL = {"revolute", "continuous", "prismatic", "fixed"}


@dataclass(frozen=True)
class Graph:
    links: list[str]
    joints: list[tuple[str, str, str, str, bool]]  # name, parent, child, type, mimic
    base: str
    tip: str

    def text(self) -> str:
        mimic = '<mimic joint="j0"/>'
        return urdf(self.links, [joint(n, p, c, k, mimic if m else "") for n, p, c, k, m in self.joints])


@st.composite
def graphs(draw: st.DrawFn) -> Graph:
    n = draw(st.integers(2, 7))
    links = [f"l{i}" for i in range(n)]
    if draw(st.integers(0, 9)) == 0:
        links.append(draw(st.sampled_from(links)))  # a duplicate link name, now and then
    endpoint = st.sampled_from([*links, "ghost"]) if draw(st.integers(0, 9)) == 0 else st.sampled_from(links)
    if draw(st.booleans()):
        # mostly trees: joint i hangs link i+1 from an earlier link, then a few arbitrary edges
        edges = [(f"l{draw(st.integers(0, i))}", f"l{i + 1}") for i in range(n - 1)]
        if draw(st.integers(0, 3)) == 0:
            edges += draw(st.lists(st.tuples(endpoint, endpoint), min_size=1, max_size=2))
    else:
        edges = draw(st.lists(st.tuples(endpoint, endpoint), max_size=n + 1))
    names = [f"j{i}" for i in range(len(edges))]
    if names and draw(st.integers(0, 9)) == 0:
        names[-1] = names[0]  # a duplicate joint name
    # mostly the serial kinds, so that a fair share of the graphs is a readable chain
    kind = st.sampled_from(KINDS) if draw(st.integers(0, 4)) == 0 else st.sampled_from(sorted(SERIAL))
    joints = [
        (name, p, c, draw(kind), draw(st.integers(0, 15)) == 0) for name, (p, c) in zip(names, edges, strict=True)
    ]
    base = "l0" if draw(st.booleans()) else draw(st.sampled_from(links))
    tip = f"l{n - 1}" if draw(st.booleans()) else draw(st.sampled_from(links))
    return Graph(links, joints, base, tip)


def expected_path(g: Graph) -> list[tuple[str, str, str, str, bool]] | None:
    """The joints from base to tip, or None when the reader must refuse: the independent, top-down reading."""
    if len(set(g.links)) < len(g.links) or len({j[0] for j in g.joints}) < len(g.joints):
        return None
    if any(p not in g.links or c not in g.links or p == c for _, p, c, _, _ in g.joints):
        return None
    children: dict[str, list[tuple[str, str, str, str, bool]]] = {}
    for j in g.joints:
        children.setdefault(j[1], []).append(j)
    roots = set(g.links) - {c for _, _, c, _, _ in g.joints}
    if len(roots) != 1:
        return None
    visits: list[str] = []

    def down(link: str, depth: int) -> None:
        if depth > len(g.links):  # only a cycle reachable from the root goes deeper than the links
            return
        visits.append(link)
        for j in children.get(link, []):
            down(j[2], depth + 1)

    down(next(iter(roots)), 0)
    if sorted(visits) != sorted(g.links):  # a tree visits every link exactly once from its root
        return None

    def search(link: str, path: list[Any]) -> list[Any] | None:
        if link == g.tip:
            return path
        for j in children.get(link, []):
            found = search(j[2], [*path, j])
            if found is not None:
                return found
        return None

    path = search(g.base, [])
    if path is None or not any(k != "fixed" for _, _, _, k, _ in path):
        return None
    if any(k not in SERIAL or (m and k != "fixed") for _, _, _, k, m in path):
        return None
    return path


@FUZZ
@given(graphs())
def test_the_urdf_reader_agrees_with_an_independent_reading(g: Graph) -> None:
    path = expected_path(g)
    try:
        document = document_from_urdf(g.text(), g.base, g.tip)
    except InvalidInput as error:
        assert path is None, f"refused a valid chain: {error}"
        assert str(error) and error.field in ("urdf", "tip_link", "base_link")
        return
    assert path is not None, "read a document the independent reading refuses"
    moving = [j for j in path if j[3] != "fixed"]
    assert len(document["stages"][0]["links"]) == len(moving)
    assert description_from_document(document).n_joints == len(moving)


@FUZZ
@given(st.binary(max_size=400).map(lambda b: b.decode("latin-1")), st.sampled_from(["l0", "base"]))
def test_any_text_is_a_document_or_an_invalid_input(text: str, base: str) -> None:
    for candidate in (text, '<robot name="r"><link name="l0"/>' + text + "</robot>"):
        with contextlib.suppress(InvalidInput):
            document_from_urdf(candidate, base, "l1")


JSON = st.recursive(
    st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)
LINK = st.fixed_dictionaries(
    {"joint": st.sampled_from(["revolute", "prismatic", "fixed", "helical"])},
    optional={
        "a": st.floats(),
        "alpha": st.floats(-400, 400),
        "d": st.floats(),
        "theta": st.floats(),
        "beta": st.floats(-10, 10),
        "range": st.lists(st.floats(), max_size=3),
    },
)
STAGE = st.fixed_dictionaries(
    {"kind": st.sampled_from(["serial", "hexapod", "other"])},
    optional={"convention": st.sampled_from(["dh", "mdh", "x"]), "links": st.lists(LINK, max_size=5)},
)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@FUZZ
@given(
    st.one_of(
        JSON,
        st.fixed_dictionaries({"stages": st.lists(STAGE | JSON, max_size=3)}, optional={"base": JSON, "tool": JSON}),
    )
)
def test_the_structure_reader_answers_any_document(document: object) -> None:
    try:
        description_from_document(document)
    except InvalidInput as error:
        assert str(error)
