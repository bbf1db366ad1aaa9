"""The criteria registry is complete: a new criterion is one class in optimal_design/criteria.py (and the
regenerated service/openapi.json), nothing else; see docs/architecture.md."""

from __future__ import annotations

import inspect
import json
from pathlib import Path

import numpy as np
import pytest

from models.errors import InvalidInput
from optimal_design.criteria import (
    CRITERIA,
    Criterion,
    DesignCriterion,
    SmoothCriterion,
    SpectralCriterion,
    cost_factor,
    criterion_of,
    parse,
)

OPENAPI = Path(__file__).parents[2] / "service" / "openapi.json"


def test_every_name_is_registered_and_every_entry_is_named_by_its_key() -> None:
    assert set(CRITERIA) == {c.value for c in Criterion}
    assert list(CRITERIA) == list(Criterion)  # registry order is the enum's (messages list them in it)
    for name, criterion in CRITERIA.items():
        assert criterion.name is Criterion(name)
        assert criterion_of(name) is criterion and criterion_of(criterion) is criterion


def test_every_name_in_the_api_schema_is_registered() -> None:
    schema = json.loads(OPENAPI.read_text())["components"]["schemas"]["Criterion"]
    assert set(schema["enum"]) == set(CRITERIA)


@pytest.mark.parametrize("name", list(CRITERIA))
def test_every_criterion_implements_its_family(name: str) -> None:
    criterion = CRITERIA[name]
    # exactly one family, and no abstract method left: the algorithms call all of them
    assert isinstance(criterion, SmoothCriterion) != isinstance(criterion, SpectralCriterion)
    assert not inspect.isabstract(type(criterion)), getattr(type(criterion), "__abstractmethods__", None)
    assert isinstance(criterion.cost_factor, float) and criterion.cost_factor > 0
    for flag in ("branchable", "targetable", "takes_d_floor", "wide_greedy_exchange"):
        assert isinstance(getattr(criterion, flag), bool), flag
    if isinstance(criterion, SmoothCriterion):
        assert criterion.power > 0
    assert criterion.default_d_floor is None or (criterion.takes_d_floor and 0 < criterion.default_d_floor <= 1)
    assert not (criterion.branchable and not isinstance(criterion, SmoothCriterion))  # branching is first order


@pytest.mark.parametrize("name", list(CRITERIA))
def test_utility_value_and_efficiency_agree(name: str) -> None:
    criterion = CRITERIA[name]
    rng = np.random.default_rng(0)
    a = rng.normal(size=(20, 4))
    m, task = a.T @ a, np.eye(4) / 4
    u = criterion.utility(m, task)
    assert np.isfinite(u) and criterion.value(m, task) == criterion.reading(u)
    assert criterion.efficiency(u, u, 4) == pytest.approx(1.0)
    assert criterion.utility(np.zeros((4, 4)), task) == -np.inf


def test_parse_keeps_its_message_and_is_case_insensitive() -> None:
    assert parse("d") is CRITERIA["D"] and parse("CONDITION") is CRITERIA["condition"]
    with pytest.raises(InvalidInput, match=r"unknown criterion 'G'; choose one of \['D', 'A', 'E', 'condition', 'I'\]"):
        parse("G")


def test_an_unknown_name_costs_as_the_dearest() -> None:
    assert cost_factor("G") == max(c.cost_factor for c in CRITERIA.values())
    assert cost_factor(Criterion.D) == 1.0


def test_design_criterion_is_the_common_base() -> None:
    assert all(isinstance(c, DesignCriterion) for c in CRITERIA.values())
