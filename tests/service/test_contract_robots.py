"""Schemathesis on the robots.md document bodies of POST /v1/robots.

The operation's schema types `structure` as an open object, so schemathesis's own generation almost never
sends a document that gets past the first key check. Here hypothesis draws documents that do: one of the
example structures (each convention, joint type, Hayati's beta on dh and mdh links, a hexapod alone), its
numbers redrawn within or across their rules, and then at most one rule of robots.md broken. Each body goes
through schemathesis's case for the operation (no 5xx, the response conforms to the OpenAPI document), and
the answer must be the rule's: 201 for a valid document, else a 422 problem naming the broken field.
"""

from __future__ import annotations

import copy
import tempfile
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import schemathesis
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from schemathesis.checks import not_a_server_error
from schemathesis.specs.openapi.checks import content_type_conformance, response_schema_conformance

from models.description.examples import (
    hexapod_alone_document,
    iiwa_like_document,
    track_arm_document,
    ur5_like_document,
)
from service.http.app import create_app
from service.settings import Settings

Document = dict[str, Any]
CHECKS = [not_a_server_error, response_schema_conformance, content_type_conformance]
_DB = Path(tempfile.mkdtemp()) / "robots-contract.db"
APP = create_app(
    Settings(database_url=f"sqlite:///{_DB}", warm_up=False, background_builds=False, job_workers=0, log_level="ERROR")
)
# Outside the inner loop: schemathesis loads the schema at import (~1.7 s a process) and the cases take seconds.
pytestmark = pytest.mark.slow
schema = schemathesis.openapi.from_asgi("/openapi.json", APP)
SERIAL_EXAMPLES: dict[str, Callable[[], Document]] = {
    "ur5-dh": lambda: ur5_like_document("dh"),
    "ur5-dh-beta": lambda: ur5_like_document("dh-beta"),
    "ur5-mdh": lambda: ur5_like_document("mdh"),
    "iiwa-mdh": iiwa_like_document,
    "track": track_arm_document,
}


@pytest.fixture(scope="module", autouse=True)
def running_app() -> Iterator[TestClient]:
    with TestClient(APP) as client:
        yield client


def _links(document: Document) -> list[dict[str, Any]]:
    links: list[dict[str, Any]] = document["stages"][0]["links"]
    return links


# Each breaker takes a valid document and a draw, breaks one rule, and returns the field the 422 must name.
Breaker = Callable[[Document, st.DrawFn], str]


def _unknown_stage_kind(doc: Document, draw: st.DrawFn) -> str:
    doc["stages"][0]["kind"] = draw(st.sampled_from(["delta", "scara", "Serial", ""]))
    return "stages[0].kind"


def _range_reversed(doc: Document, draw: st.DrawFn) -> str:
    moving = [k for k, link in enumerate(_links(doc)) if link["joint"] != "fixed"]
    k = draw(st.sampled_from(moving))
    lo = draw(st.floats(-170, 170))
    _links(doc)[k]["range"] = [lo, lo - draw(st.floats(0, 100))]  # lo >= hi
    return f"stages[0].links[{k}].range"


def _no_moving_joint(doc: Document, draw: st.DrawFn) -> str:
    for link in _links(doc):
        link["joint"] = "fixed"
        link.pop("range", None)
    return "stages"


def _beta_where_axes_are_not_parallel(doc: Document, draw: st.DrawFn) -> str:
    skew = [k for k, link in enumerate(_links(doc)) if abs(link["alpha"]) not in (0.0, 180.0)]
    k = draw(st.sampled_from(skew))
    _links(doc)[k]["beta"] = draw(st.floats(-1, 1))
    return f"stages[0].links[{k}].beta"


def _moving_joint_without_range(doc: Document, draw: st.DrawFn) -> str:
    moving = [k for k, link in enumerate(_links(doc)) if link["joint"] != "fixed"]
    k = draw(st.sampled_from(moving))
    del _links(doc)[k]["range"]
    return f"stages[0].links[{k}].range"


def _not_a_number(doc: Document, draw: st.DrawFn) -> str:
    k = draw(st.integers(0, len(_links(doc)) - 1))
    key = draw(st.sampled_from(["a", "alpha", "d", "theta"]))
    _links(doc)[k][key] = draw(st.sampled_from(["x", None, [1.0], "1e999", True]))
    return f"stages[0].links[{k}].{key}"


def _unknown_joint_type(doc: Document, draw: st.DrawFn) -> str:
    k = draw(st.integers(0, len(_links(doc)) - 1))
    _links(doc)[k]["joint"] = draw(st.sampled_from(["ball", "spherical", "Revolute"]))
    return f"stages[0].links[{k}].joint"


def _second_hexapod(doc: Document, draw: st.DrawFn) -> str:
    doc["stages"] += [hexapod_alone_document()["stages"][0], hexapod_alone_document()["stages"][0]]
    return f"stages[{len(doc['stages']) - 1}].kind"


SERIAL_BREAKERS: tuple[Breaker | None, ...] = (
    None,
    _unknown_stage_kind,
    _range_reversed,
    _no_moving_joint,
    _beta_where_axes_are_not_parallel,
    _moving_joint_without_range,
    _not_a_number,
    _unknown_joint_type,
    _second_hexapod,
)


def _collinear_joints(doc: Document, draw: st.DrawFn) -> str:
    step = draw(st.floats(1, 100))
    doc["stages"][0]["base_joints"] = [[i * step, 0.0, 0.0] for i in range(6)]
    return "stages[0].base_joints"


def _home_outside_the_workspace(doc: Document, draw: st.DrawFn) -> str:
    stage = doc["stages"][0]
    z_hi = stage["workspace"]["z"][1]
    stage["home"] = {"position": [0.0, 0.0, z_hi + draw(st.floats(1, 1000))], "orientation": [1.0, 0.0, 0.0, 0.0]}
    return "stages[0].home"


def _strokes_reversed(doc: Document, draw: st.DrawFn) -> str:
    lo = draw(st.floats(100, 600))
    doc["stages"][0]["strokes"] = [lo, lo - draw(st.floats(0, 50))]
    return "stages[0].strokes"


HEXAPOD_BREAKERS: tuple[Breaker | None, ...] = (
    None,
    _collinear_joints,
    _home_outside_the_workspace,
    _strokes_reversed,
    _unknown_stage_kind,
)


RULES: dict[str, tuple[bool, Breaker | None]] = {
    **{f"serial:{b.__name__.strip('_') if b else 'valid'}": (False, b) for b in SERIAL_BREAKERS},
    **{f"hexapod:{b.__name__.strip('_') if b else 'valid'}": (True, b) for b in HEXAPOD_BREAKERS},
}


@st.composite
def documents(draw: st.DrawFn, hexapod: bool, breaker: Breaker | None) -> tuple[Document, str | None]:
    """A robots.md document with `breaker`'s rule broken, and the field its 422 must name (None: valid)."""
    if hexapod:
        doc = hexapod_alone_document()
    else:
        doc = copy.deepcopy(SERIAL_EXAMPLES[draw(st.sampled_from(sorted(SERIAL_EXAMPLES)))]())
        # Another robot of the same structure: lengths redrawn (the structure, and so its build, is shared).
        for link in _links(doc):
            for key in ("a", "d"):
                if link[key] != 0.0:
                    link[key] = draw(st.floats(0.5, 2.0)) * link[key]
    field = None if breaker is None else breaker(doc, draw)
    return doc, field


@pytest.mark.parametrize("rule", list(RULES))
def test_robot_documents_reach_each_rule_of_robots_md(rule: str) -> None:
    hexapod, breaker = RULES[rule]

    @given(drawn=documents(hexapod, breaker))
    @settings(max_examples=6, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    def check(drawn: tuple[Document, str | None]) -> None:
        document, field = drawn
        case = schema["/v1/robots"]["POST"].Case(
            body={"name": f"fuzz-{uuid.uuid4().hex[:12]}", "structure": document}, media_type="application/json"
        )
        response = case.call_and_validate(checks=CHECKS)
        if field is None:
            assert response.status_code == 201, response.text
            assert response.json()["model"] == "custom"
        else:
            assert response.status_code == 422, response.text
            assert response.json()["field"] == field, response.text

    check()
