"""What both error trees (`models.errors`, `service.errors`) promise, checked the same way for each class."""

from __future__ import annotations

import inspect
import json
from typing import Any


def keyword_fields(cls: type[Exception]) -> list[str]:
    params = inspect.signature(cls.__init__).parameters.values()
    return [p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY]


def check_declared_fields(cls: Any, sample: dict[str, Any]) -> None:
    """The constructor's keyword-only arguments are the class's `fields`, each reaches `.data` in that order,
    and `.data` is JSON-safe."""
    names = keyword_fields(cls)
    assert set(names) == set(cls.fields), "the constructor's keyword-only arguments are the class's fields"
    exc = cls("what went wrong", **{n: sample[n] for n in names})
    assert exc.detail == str(exc) == "what went wrong"
    assert list(exc.data) == list(cls.fields)
    assert exc.data == {n: sample[n] for n in cls.fields}
    json.dumps(exc.data, allow_nan=False)
