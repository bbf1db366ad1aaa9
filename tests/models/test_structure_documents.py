"""Bad description documents: every rule of shared/spec/robots.md is refused with a domain error naming the
field, and good documents come back from `description_document` unchanged."""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from models import forward_kinematics, sample_workspace
from models.description.examples import hexapod_alone_document, iiwa_like_document, ur5_like, ur5_like_document
from models.description.structure import description_document, description_from_document
from models.errors import InvalidInput

Doc = dict[str, Any]


def _arm() -> Doc:
    return iiwa_like_document()


def _hex() -> Doc:
    return hexapod_alone_document()


def _set(make: Callable[[], Doc], change: Callable[[Doc], object]) -> Doc:
    doc = copy.deepcopy(make())
    change(doc)
    return doc


def _link0(doc: Doc) -> Doc:
    link: Doc = doc["stages"][0]["links"][0]
    return link


def _hexstage(doc: Doc) -> Doc:
    stage: Doc = doc["stages"][0]
    return stage


BAD: list[tuple[str, Doc | object, str]] = [
    ("not an object", [], "structure"),
    ("unknown key", _set(_arm, lambda d: d.update(colour="red")), "structure.colour"),
    ("no stages", {"stages": []}, "stages"),
    ("unknown stage kind", _set(_arm, lambda d: d["stages"][0].update(kind="delta")), "stages[0].kind"),
    ("unknown convention", _set(_arm, lambda d: d["stages"][0].update(convention="sdh")), "stages[0].convention"),
    ("no links", _set(_arm, lambda d: d["stages"][0].update(links=[])), "stages[0].links"),
    ("unknown joint", _set(_arm, lambda d: _link0(d).update(joint="spherical")), "stages[0].links[0].joint"),
    ("range lo >= hi", _set(_arm, lambda d: _link0(d).update(range=[10, 10])), "stages[0].links[0].range"),
    ("range missing", _set(_arm, lambda d: _link0(d).pop("range")), "stages[0].links[0].range"),
    ("fixed with range", _set(_arm, lambda d: _link0(d).update(joint="fixed")), "stages[0].links[0].range"),
    ("not a number", _set(_arm, lambda d: _link0(d).update(a="ten")), "stages[0].links[0].a"),
    ("non-finite", _set(_arm, lambda d: _link0(d).update(d=float("nan"))), "stages[0].links[0].d"),
    (
        "beta on a non-parallel link",
        _set(_arm, lambda d: d["stages"][0]["links"][1].update(beta=0.1)),
        "stages[0].links[1].beta",
    ),
    (
        "no moving joint",
        {"stages": [{"kind": "serial", "convention": "dh", "links": [{"joint": "fixed", "a": 1.0}]}]},
        "stages",
    ),
    ("two hexapods", _set(_hex, lambda d: d["stages"].append(copy.deepcopy(d["stages"][0]))), "stages[1].kind"),
    (
        "collinear base joints",
        _set(_hex, lambda d: _hexstage(d).update(base_joints=[[float(k), 0.0, 0.0] for k in range(6)])),
        "stages[0].base_joints",
    ),
    (
        "five platform joints",
        _set(_hex, lambda d: _hexstage(d)["platform_joints"].pop()),
        "stages[0].platform_joints",
    ),
    ("stroke lo >= hi", _set(_hex, lambda d: _hexstage(d).update(strokes=[400, 300])), "stages[0].strokes"),
    (
        "home outside the workspace",
        _set(_hex, lambda d: _hexstage(d)["home"].update(position=[0.0, 0.0, 360.0])),
        "stages[0].home",
    ),
    ("home beyond the strokes", _set(_hex, lambda d: _hexstage(d).update(strokes=[260, 300])), "stages[0].home"),
    (
        "workspace lo >= hi",
        _set(_hex, lambda d: _hexstage(d)["workspace"].update(rz=[5, -5])),
        "stages[0].workspace.rz",
    ),
    (
        "not a unit quaternion",
        _set(_arm, lambda d: d.update(tool={"position": [0, 0, 0], "orientation": [2, 0, 0, 0]})),
        "tool.orientation",
    ),
]


@pytest.mark.parametrize(("label", "doc", "field"), BAD, ids=[b[0] for b in BAD])
def test_bad_documents_name_the_field(label: str, doc: object, field: str) -> None:
    with pytest.raises(InvalidInput) as err:
        description_from_document(doc)
    assert err.value.field == field, label


@pytest.mark.parametrize("make", [_arm, _hex])
def test_documents_read_back(make: Callable[[], Doc]) -> None:
    desc = description_from_document(make())
    again = description_from_document(description_document(desc))
    assert again.structure == desc.structure
    assert again.parameters.names == desc.parameters.names
    assert max(abs(a - b) for a, b in zip(again.parameters.nominal, desc.parameters.nominal, strict=True)) < 1e-9


@pytest.mark.parametrize("convention", ["mdh", "dh-beta"])
def test_a_calibrated_document_reads_back_as_the_same_structure(convention: str) -> None:
    # GET /v1/robots/{id}/structure?version=n writes the identified values: the twist of a parallel pair is then
    # a fraction of a degree off 0, and the document (with its beta) must still be accepted, as the same
    # structure, with the same forward kinematics.
    desc = ur5_like(convention)
    theta = desc.parameters.nominal + np.random.default_rng(5).normal(size=desc.n_params) * desc.parameters.scales
    document = description_document(desc, theta)
    alphas = [link["alpha"] for link in document["stages"][0]["links"] if "beta" in link]
    assert alphas and all(0 < abs(a) < 1.0 for a in alphas)  # off parallel, as calibrated
    back = description_from_document(document)
    assert back.structure == desc.structure and back.n_params == desc.n_params
    q = sample_workspace(desc, 10, seed=6)
    np.testing.assert_allclose(
        forward_kinematics(back, q).positions, forward_kinematics(desc, q, theta).positions, atol=1e-9
    )


def test_beta_is_accepted_only_near_parallel_axes() -> None:
    near = ur5_like_document("dh")
    near["stages"][0]["links"][1] |= {"alpha": 3.0, "beta": 0.1}
    assert "link2.beta" in description_from_document(near).parameters.index
    far = ur5_like_document("dh")
    far["stages"][0]["links"][1] |= {"alpha": 10.0, "beta": 0.1}
    with pytest.raises(InvalidInput) as refused:
        description_from_document(far)
    assert refused.value.field == "stages[0].links[1].beta"
    # Without the key, only exactly parallel mdh links get beta: a 3° mdh twist is a plain link.
    mdh = ur5_like_document("mdh")
    mdh["stages"][0]["links"][2]["alpha"] = 3.0
    assert "link3.beta" not in description_from_document(mdh).parameters.index
