"""Property-based fuzz of the robot importers' numbers and of UR's kinematics file (issue 48): whatever the
numbers and the YAML, a robots.md document of finite numbers or an InvalidInput, never another exception (the
probe's `<origin xyz="1e308 0 0">` was an internal assertion, a 500), a warning (every warning is an error in the
tests: an overflow on the way is one) or a second's work.

`tests/models/test_urdf_fuzz.py` draws the URDF's joint graphs; here the graph is a plain chain and the numbers
are drawn: origins, angles, axes and limits at and beyond the double's range, as text a URDF or a YAML file can
hold. `make test` draws IWR_URDF_FUZZ_EXAMPLES (default 60) per property, `make fuzz` 2 000."""

from __future__ import annotations

import math
import os
from datetime import timedelta
from typing import Any

import pytest
import yourdfpy  # noqa: F401  (imported here so that its first import is not inside an example's deadline)
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from models.description.structure import description_from_document
from models.errors import InvalidInput
from models.formats.ur_kinematics import BASE_LINK, KEYS, SEGMENTS, TIP_LINK, read_kinematics, urdf_of_kinematics
from models.formats.urdf import document_from_urdf

EXAMPLES = int(os.environ.get("IWR_URDF_FUZZ_EXAMPLES", "60"))
FUZZ = settings(
    max_examples=EXAMPLES,
    deadline=timedelta(seconds=1),
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=EXAMPLES <= 60,
)
EDGES = [
    "0",
    "-0",
    "1",
    "0.5",
    "-0.425",
    "3.141592653589793",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e400",
    "-1e400",
    "5e-324",
    "1e-320",
    "nan",
    "inf",
    "-inf",
    "1e15",
    "999",
    "1000",
    "1001",
    "1" * 40,
]
numbers = st.one_of(
    st.sampled_from(EDGES),
    st.floats(allow_nan=False, allow_infinity=False, width=64).map(repr),
    st.floats(-2.0, 2.0).map(repr),  # mostly readable arms
    st.floats(-2.0, 2.0).map(repr),
)


def _finite_numbers(node: Any) -> bool:
    if isinstance(node, dict):
        return all(_finite_numbers(v) for v in node.values())
    if isinstance(node, list | tuple):
        return all(_finite_numbers(v) for v in node)
    return not isinstance(node, float) or math.isfinite(node)


@st.composite
def numeric_urdfs(draw: st.DrawFn) -> str:
    n = draw(st.integers(1, 4))
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = []
    for i in range(n):
        kind = draw(st.sampled_from(["revolute", "revolute", "continuous", "prismatic", "fixed"]))
        xyz = " ".join(draw(numbers) for _ in range(3))
        rpy = " ".join(draw(numbers) for _ in range(3))
        axis = " ".join(draw(numbers) for _ in range(3)) if draw(st.integers(0, 2)) == 0 else "0 0 1"
        limit = f'<limit lower="{draw(numbers)}" upper="{draw(numbers)}" effort="0" velocity="0"/>'
        joints.append(
            f'<joint name="j{i}" type="{kind}"><parent link="l{i}"/><child link="l{i + 1}"/>'
            f'<origin xyz="{xyz}" rpy="{rpy}"/><axis xyz="{axis}"/>{limit}</joint>'
        )
    return f'<robot name="r">{links}{"".join(joints)}</robot>'


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@FUZZ
@given(numeric_urdfs())
def test_any_urdf_numbers_are_a_finite_document_or_an_invalid_input(text: str) -> None:
    n = text.count("<joint ")
    try:
        document = document_from_urdf(text, "l0", f"l{n}")
        description_from_document(document)
    except InvalidInput as error:
        assert str(error)
        return
    assert _finite_numbers(document), document


def _segment_yaml(draw: st.DrawFn) -> str:
    form = draw(st.integers(0, 9))
    if form == 0:  # something that is not a mapping of numbers
        return draw(st.sampled_from(["[]", "null", "x", "[1, 2]", "{x: [1]}", "!!binary aGk=", "&a {x: 1}", "*a"]))
    keys = list(KEYS) if form > 2 else draw(st.lists(st.sampled_from([*KEYS, "w", "1", "~"]), max_size=7))
    odd = st.sampled_from(["yes", "0x10", "1_0", ".inf", ".nan"])
    return "{" + ", ".join(f"{k}: {draw(numbers | odd)}" for k in keys) + "}"


@st.composite
def kinematics_files(draw: st.DrawFn) -> str:
    names = list(SEGMENTS) if draw(st.integers(0, 4)) else draw(st.lists(st.sampled_from([*SEGMENTS, "elbow"])))
    lines = ["kinematics:", *(f"  {name}: {_segment_yaml(draw)}" for name in names)]
    if draw(st.booleans()):
        lines.append(f"  hash: {draw(st.sampled_from(['calib_1', '[', '{a: 1}', '1e400']))}")
    return "\n".join(lines) + "\n"


YAML_TEXT = st.text(alphabet="[]{}:,-?!&*|>'\"#%@` \n\tax1.e+", max_size=300)


@pytest.mark.slow  # ~1 s here: outside the inner loop (make test-fast)
@FUZZ
@given(st.one_of(kinematics_files(), YAML_TEXT))
def test_any_ur_kinematics_file_is_a_robot_or_an_invalid_input(text: str) -> None:
    # The import's whole path: the file's origins, the URDF ur_description would build, the chain read back.
    try:
        origins = read_kinematics(text)
        document = document_from_urdf(urdf_of_kinematics(origins), BASE_LINK, TIP_LINK)
        description_from_document(document)
    except InvalidInput as error:
        assert str(error) and (error.field or "").startswith("document")
        return
    assert _finite_numbers(document)
