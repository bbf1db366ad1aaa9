"""Hostile URDFs (issue 31): each attack is refused with an InvalidInput naming the fix, in linear time.

Before, a cycle (l1 -> l2 -> l1) sent the walk from the tip towards the base round forever, its path growing
~85 MB/s until the OOM killer. Each test here runs under the per-test timeout; the cycle's also checks that
memory stayed flat and that the answer came within a second."""

from __future__ import annotations

import resource
import time

import pytest

from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.urdf import document_from_urdf
from models.formats.urdf_tree import MAX_LINKS
from tests.linearity import LINEAR_RATIO, best_doubling_ratio

LIMIT = '<limit lower="-1" upper="1" effort="0" velocity="0"/>'


def joint(name: str, parent: str, child: str, kind: str = "revolute", extra: str = "") -> str:
    body = f'<axis xyz="0 0 1"/>{LIMIT}' if kind in ("revolute", "prismatic") else ""
    return (
        f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0.1 0 0.2" rpy="0 0.3 0"/>{body}{extra}</joint>'
    )


def urdf(links: list[str], joints: list[str]) -> str:
    return '<robot name="r">' + "".join(f'<link name="{n}"/>' for n in links) + "".join(joints) + "</robot>"


def chain(n: int) -> str:
    """A serial chain of n revolute joints, l0 (base) to l{n} (tip)."""
    return urdf([f"l{i}" for i in range(n + 1)], [joint(f"j{i}", f"l{i}", f"l{i + 1}") for i in range(n)])


def refused(text: str, base: str = "l0", tip: str = "l2") -> InvalidInput:
    with pytest.raises(InvalidInput) as caught:
        document_from_urdf(text, base, tip)
    return caught.value


def test_a_valid_chain_still_reads() -> None:
    desc = description_from_document(document_from_urdf(chain(3), "l0", "l3"))
    assert desc.n_joints == 3


def _max_rss_kb() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss


def test_a_cycle_is_refused_at_once_with_memory_flat() -> None:
    # l0 is the root; l1 <-> l2 is a loop hanging from nothing: the 600-byte request.
    text = urdf(["l0", "l1", "l2"], [joint("a", "l1", "l2"), joint("b", "l2", "l1")])
    # CPU time, not wall time: the refusal is computed in this process, and a busy machine must not fail it.
    before, start = _max_rss_kb(), time.process_time()
    error = refused(text, base="l0", tip="l2")
    assert time.process_time() - start < 1.0
    assert _max_rss_kb() - before < 20_000  # kB: the walk grew ~85 MB/s before
    assert error.reason == "cycle" and "'a', 'b'" in str(error) and "remove one joint" in str(error)


def test_a_self_loop_is_refused() -> None:
    error = refused(urdf(["l0", "l1"], [joint("j0", "l0", "l1"), joint("self", "l1", "l1")]), tip="l1")
    assert "connects link 'l1' to itself" in str(error)


def test_a_cycle_through_the_root_side_is_named() -> None:
    # l0 -> l1 -> l2 -> l3 -> l1: l1 has two parents, the first thing a tree forbids.
    text = urdf(
        ["l0", "l1", "l2", "l3"],
        [joint("a", "l0", "l1"), joint("b", "l1", "l2"), joint("c", "l2", "l3"), joint("d", "l3", "l1")],
    )
    error = refused(text, tip="l3")
    assert "link 'l1' is the child of two joints, 'a' and 'd'" in str(error)


def test_a_longer_cycle_without_a_root_is_named_in_order() -> None:
    text = urdf(
        ["l0", "l1", "l2", "l3"],
        [joint("a", "l1", "l2"), joint("b", "l2", "l3"), joint("c", "l3", "l1")],
    )
    error = refused(text, tip="l3")
    assert error.reason == "cycle" and error.value == "a, b, c"


def test_several_roots_are_refused() -> None:
    text = urdf(["l0", "l1", "l2", "x"], [joint("a", "l0", "l1"), joint("b", "l1", "l2")])
    error = refused(text)
    assert error.reason == "several_roots" and "'l0', 'x'" in str(error) and "fixed joints" in str(error)


def test_a_tip_not_below_the_base_is_refused() -> None:
    text = urdf(["l0", "l1", "l2", "l3"], [joint("a", "l0", "l1"), joint("b", "l1", "l2"), joint("c", "l0", "l3")])
    error = refused(text, base="l3", tip="l2")
    assert error.field == "tip_link" and "root 'l0'" in str(error) and "choose a base_link" in str(error)


@pytest.mark.parametrize("size", [MAX_LINKS + 1, 10_000])
def test_too_many_links_are_refused_before_parsing(size: int) -> None:
    start = time.process_time()
    error = refused(chain(size), tip=f"l{size}")
    assert time.process_time() - start < 1.0
    assert error.reason == "too_large" and error.max == MAX_LINKS and f"at most {MAX_LINKS}" in str(error)


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
def test_the_largest_accepted_chain_reads() -> None:
    doc = document_from_urdf(chain(MAX_LINKS - 1), "l0", f"l{MAX_LINKS - 1}")
    assert len(doc["stages"][0]["links"]) == MAX_LINKS - 1


@pytest.mark.parametrize("kind", ["floating", "planar"])
def test_floating_and_planar_joints_in_the_chain_are_refused(kind: str) -> None:
    text = urdf(["l0", "l1", "l2"], [joint("a", "l0", "l1"), joint("free", "l1", "l2", kind)])
    error = refused(text)
    assert f"'free' is {kind}" in str(error) and "make it fixed" in str(error)


def test_a_floating_joint_outside_the_chain_is_harmless() -> None:
    # A mobile base's floating joint above the arm: choose the arm's own base, and it reads.
    text = urdf(
        ["odom", "l0", "l1", "l2"],
        [joint("f", "odom", "l0", "floating"), joint("a", "l0", "l1"), joint("b", "l1", "l2")],
    )
    assert len(document_from_urdf(text, "l0", "l2")["stages"][0]["links"]) == 2


def test_a_mimic_joint_in_the_chain_is_refused() -> None:
    mimic = '<mimic joint="a" multiplier="1" offset="0"/>'
    text = urdf(["l0", "l1", "l2"], [joint("a", "l0", "l1"), joint("m", "l1", "l2", extra=mimic)])
    error = refused(text)
    assert "'m' mimics joint 'a'" in str(error) and "remove its <mimic>" in str(error)


@pytest.mark.parametrize(
    ("kind", "links", "joints"),
    [
        ("link", ["l0", "l1", "l1", "l2"], [("a", "l0", "l1"), ("b", "l1", "l2")]),
        ("joint", ["l0", "l1", "l2"], [("a", "l0", "l1"), ("a", "l1", "l2")]),
    ],
)
def test_duplicate_names_are_refused(kind: str, links: list[str], joints: list[tuple[str, str, str]]) -> None:
    error = refused(urdf(links, [joint(*j) for j in joints]))
    assert f"two {kind}s named" in str(error) and "rename one" in str(error)


def test_a_joint_to_an_undefined_link_is_refused() -> None:
    error = refused(urdf(["l0", "l1", "l2"], [joint("a", "l0", "l1"), joint("b", "l1", "ghost")]))
    assert "child link 'ghost'" in str(error)


def test_a_zero_axis_is_refused() -> None:
    text = urdf(["l0", "l1", "l2"], [joint("a", "l0", "l1"), joint("b", "l1", "l2")]).replace(
        '<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>', 1
    )
    assert "non-zero <axis xyz>" in str(refused(text))


@pytest.mark.serial
def test_reading_is_linear_in_the_links() -> None:
    texts = {n: chain(n) for n in (250, 500)}
    assert best_doubling_ratio(lambda n: document_from_urdf(texts[n], "l0", f"l{n}"), 250) <= LINEAR_RATIO


def ring(n: int) -> str:
    """A root l0 and a ring of n links that no root reaches."""
    joints = [joint(f"r{i}", f"l{i + 1}", f"l{(i + 1) % n + 1}") for i in range(n)]
    return urdf([f"l{i}" for i in range(n + 1)], joints)


@pytest.mark.serial
def test_refusing_a_cycle_is_linear_in_the_links() -> None:
    texts = {n: ring(n) for n in (400, 800)}

    def refuse(n: int) -> None:
        with pytest.raises(InvalidInput, match="form a cycle"):
            document_from_urdf(texts[n], "l0", "l1")

    assert best_doubling_ratio(refuse, 400) <= LINEAR_RATIO
