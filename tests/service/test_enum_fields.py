"""Audit actions, joint types and measurement kinds are defined once, as enums; the schemas publish each as the
inline `enum` of its values a Literal gives (the contract), and hand the code the enum's member."""

from __future__ import annotations

from enum import StrEnum
from typing import Literal

import pytest
from pydantic import BaseModel, TypeAdapter, ValidationError

from models.description.serial_chain import JointType
from models.measurement import MeasurementKind
from service.audit_actions import AuditAction
from service.schemas.audit import Action
from service.schemas.common import Measurement
from service.schemas.structure import Joint


@pytest.mark.parametrize(("field", "enum"), [(Action, AuditAction), (Joint, JointType), (Measurement, MeasurementKind)])
def test_a_derived_field_publishes_and_refuses_as_the_literal_of_its_values(field: object, enum: type[StrEnum]) -> None:
    values = tuple(member.value for member in enum)

    class Derived(BaseModel):
        x: field  # type: ignore[valid-type]

    class Spelt(BaseModel):
        x: Literal[values]  # type: ignore[valid-type]

    assert Derived.model_json_schema() == {**Spelt.model_json_schema(), "title": "Derived"}
    with pytest.raises(ValidationError) as derived:
        Derived(x="nonsense")
    with pytest.raises(ValidationError) as spelt:
        Spelt(x="nonsense")
    assert derived.value.errors() == spelt.value.errors()  # the 422's words too
    held = Derived(x=values[-1]).x
    assert type(held) is enum and held == values[-1]
    assert TypeAdapter(Derived).dump_python(Derived(x=values[0]), mode="json") == {"x": values[0]}
