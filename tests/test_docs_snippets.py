"""Every Python snippet of the project's documentation runs as it is written (a user copies them)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted((ROOT / "docs").glob("*.md"))
BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)
SNIPPETS = [(doc, k, code) for doc in DOCS for k, code in enumerate(BLOCK.findall(doc.read_text()))]
SLOW_DOCS = {"pose-design.md", "compensation.md", "controller.md", "fleet.md"}
"""Pages whose snippets take over a second (a design, inverse kinematics, calibrations): outside `make test-fast`."""
CASES = [
    pytest.param(doc, k, code, id=f"{doc.name}#{k}", marks=[pytest.mark.slow] if doc.name in SLOW_DOCS else [])
    for doc, k, code in SNIPPETS
]


@pytest.mark.slow  # over 0.25 s of CPU: outside the inner loop (make test-fast)
@pytest.mark.parametrize(("doc", "k", "code"), CASES)
def test_the_snippet_runs(doc: Path, k: int, code: str, capsys: pytest.CaptureFixture[str]) -> None:
    exec(compile(code, f"{doc.name} snippet {k}", "exec"), {"__name__": f"snippet_{k}"})
    assert capsys.readouterr().out or "print(" not in code


def test_there_are_snippets_to_run() -> None:
    assert any(doc.name == "instruments.md" for doc, _, _ in SNIPPETS)
