"""README's layout section matches the tree: every path it names exists, and every file of a folder it lists
entry by entry is named in that folder's lines (a module added, moved or removed fails here)."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ENTRY = re.compile(r"^( *)([\w.\-]+/?)(?:\s|$)")
DESCRIPTION_COLUMN = 19
"""Entries sit left of the descriptions' column; a wrapped description line starts at or after it."""
UNLISTED = ("__init__.py",)


def _tracked() -> set[str]:
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout: the tree to compare with is git's")
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return set(out.split())


def _layout() -> tuple[list[str], dict[str, str]]:
    """(every path the block names, each folder's lines as one text)."""
    readme = (ROOT / "README.md").read_text()
    section = readme[readme.index("## Layout") :]
    block = section[section.index("```") + 3 :]
    block = block[block.index("\n") + 1 : block.index("```")]
    entries: list[str] = []
    texts: dict[str, list[str]] = {}
    stack: list[tuple[int, str]] = []
    for line in block.splitlines():
        m = ENTRY.match(line)
        name = m.group(2) if m else ""
        if m and len(m.group(1)) < DESCRIPTION_COLUMN and (name.endswith("/") or "." in name):
            indent = len(m.group(1))
            while stack and stack[-1][0] >= indent:
                stack.pop()
            path = (stack[-1][1] if stack else "") + name
            entries.append(path)
            if path.endswith("/"):
                stack.append((indent, path))
        for _, folder in stack:
            texts.setdefault(folder, []).append(line)
    return entries, {folder: "\n".join(lines) for folder, lines in texts.items()}


def test_the_layout_names_what_the_tree_holds() -> None:
    tracked = _tracked()
    folders = {str(Path(p).parent) + "/" for p in tracked}
    folders |= {str(parent) + "/" for p in tracked for parent in Path(p).parents if str(parent) != "."}
    entries, texts = _layout()
    assert len(entries) > 50, "the layout block was not found or not read"
    missing = [e for e in entries if e not in tracked and e not in folders]
    assert not missing, f"the layout names what the tree does not have: {missing}"
    listed = {e for e in entries if e.endswith("/") and any(x != e and x.startswith(e) for x in entries)}
    unnamed = []
    for folder in sorted(listed):
        names = set(re.findall(r"[\w.\-]+/?", texts.get(folder, "")))
        for path in tracked:
            if not path.startswith(folder):
                continue
            rest = path[len(folder) :]
            child = rest.split("/")[0] + ("/" if "/" in rest else "")
            if child in UNLISTED or child.endswith(".md") or child in names or child.rstrip("/") in names:
                continue
            unnamed.append(folder + child)
    assert not unnamed, f"add these to README's layout section: {sorted(set(unnamed))}"
