"""The rewrite changes the numbers of the corrected targets and not one other character; the numbers it writes
read back as the poses it was given, in the source's style."""

from __future__ import annotations

import re

import numpy as np
import pytest

from models._types import Array
from programs import PROGRAM, Program, Target, read_program, rewritten
from programs.frames import abc_matrix
from programs.numbers import styled
from tests.programs.samples import CSV, KRL_CONFIG, KRL_DAT, KRL_SRC, RAPID_MOD, URSCRIPT

SAMPLES = {
    "krl": (KRL_SRC, {"Weld_Seam.dat": KRL_DAT, "$config.dat": KRL_CONFIG}),
    "rapid": (RAPID_MOD, {}),
    "urscript": (URSCRIPT, {}),
    "csv": (CSV, {}),
}
NUMBER = re.compile(r"(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)")
"""Digits, the way any of the four languages writes an unsigned number: the text between them must not change
(a sign is text: a correction that flips one changes only the characters of its own number's slot)."""


def _moved(pose: Array, k: int) -> Array:
    """A correction of the size compensation makes: tenths of a millimetre, hundredths of a degree."""
    turn = np.eye(4)
    turn[:3, :3] = abc_matrix(0.01 * (k + 1), -0.02, 0.015)
    turn[:3, 3] = [0.1 * (k + 1), -0.25, 0.05]
    return np.asarray(pose @ turn)


def _changes(program: Program) -> list[tuple[Target, Array]]:
    return [(t, _moved(t.pose, k)) for k, t in enumerate(program.targets) if t.kept is None]


def _slot_spans(program: Program, file: str | None) -> list[tuple[int, int]]:
    return [(s.start, s.end) for t in program.targets if t.kept is None for s in t.slots if s.file == file]


def _rewritten_sample(format_name: str) -> tuple[Program, dict[str | None, str]]:
    """A sample program and its texts with every target it can correct moved."""
    text, files = SAMPLES[format_name]
    program = read_program(format_name, text, files)
    return program, rewritten(program, _changes(program))


@pytest.mark.parametrize("format_name", sorted(SAMPLES))
def test_only_the_numbers_of_the_corrected_targets_change(format_name: str) -> None:
    program, out = _rewritten_sample(format_name)
    for name, before in program.texts.items():
        after = out[name]
        old_parts, new_parts = NUMBER.split(before), NUMBER.split(after)
        assert [p.rstrip("-+") for p in old_parts[0::2]] == [p.rstrip("-+") for p in new_parts[0::2]]
        assert after.count("\r\n") == before.count("\r\n") and after.count("\n") == before.count("\n")
        spans = _slot_spans(program, name)
        offsets = [m.start() for m in NUMBER.finditer(before)]
        for k, (old, new) in enumerate(zip(old_parts[1::2], new_parts[1::2], strict=True)):
            if old != new:
                assert any(a <= offsets[k] < b for a, b in spans), (name, offsets[k], old, new)


@pytest.mark.parametrize("format_name", sorted(SAMPLES))
def test_outside_the_slots_every_character_is_kept(format_name: str) -> None:
    program, out = _rewritten_sample(format_name)
    for name, before in program.texts.items():
        spans = sorted(_slot_spans(program, name))
        kept_before, at = [], 0
        for a, b in spans:
            kept_before.append(before[at:a])
            at = b
        kept_before.append(before[at:])
        after = out[name]
        # the same pieces, in order, with only numbers between them
        pattern = r"[-+]?[\d.eE+-]+".join(re.escape(piece) for piece in kept_before)
        assert re.fullmatch(pattern, after, flags=re.DOTALL), name


@pytest.mark.parametrize("format_name", sorted(SAMPLES))
def test_the_written_numbers_read_back_as_the_new_poses(format_name: str) -> None:
    text, files = SAMPLES[format_name]
    program = read_program(format_name, text, files)
    changes = _changes(program)
    out = rewritten(program, changes)
    again = read_program(format_name, out[PROGRAM], {k: v for k, v in out.items() if k is not None})
    wanted = {program.targets.index(t): pose for t, pose in changes}
    assert len(again.targets) == len(program.targets)
    for k, t in enumerate(again.targets):
        if k in wanted:
            pose = wanted[k]
            assert np.abs(t.pose[:3, 3] - pose[:3, 3]).max() < 2e-3  # 1 µm decimals (metres: 1e-6 m)
            assert np.abs(t.pose[:3, :3] - pose[:3, :3]).max() < 1e-5
        else:
            assert t.kept is not None


def test_the_source_style_is_kept() -> None:
    program = read_program("rapid", RAPID_MOD, {})
    approach = next(t for t in program.targets if t.name == "pApproach")
    written = rewritten(program, [(approach, _moved(approach.pose, 0))])[PROGRAM]
    line = written.splitlines()[8]
    assert ",[-1,0,-1,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];" in line  # confdata and axes as written
    assert re.search(r"\[\[250\.\d{3},-12\.\d{3},\d+\.\d{3}\],\[-?0\.\d{6},", line), line
    ur = read_program("urscript", URSCRIPT, {})
    w2 = next(t for t in ur.targets if t.name == "Waypoint_2_p")
    text = rewritten(ur, [(w2, w2.pose)])[PROGRAM]
    assert "p[0.450000,-0.100000,0.300000,0.000000,-3.141600,0.000000]" in text  # the half turn spelt as before


@pytest.mark.parametrize(
    ("value", "like", "decimals", "out"),
    [
        (1224.53219, "1224.5", 3, "1224.532"),
        (1224.5, "1224.5000000", 3, "1224.5000000"),
        (-0.00001, "0", 3, "0.000"),
        (0.4000004, ".4", 6, ".400000"),
        (1500.25, "1.5E3", 3, "1.500250E3"),
        (0.25, "9E+09", 2, "2.5E-01"),
        (3.0, "+2", 1, "+3.0"),
        (-0.0000004, "-0.25", 6, "0.000000"),  # the plain spelling's own path: rounds to zero, no sign
        (-12.3456789, " -0.25 ", 2, "-12.35"),
        (2.0, "-.5", 1, "2.0"),
        (2.0, "-1.", 0, "2"),
    ],
)
def test_numbers_keep_their_style(value: float, like: str, decimals: int, out: str) -> None:
    assert styled(value, like, decimals) == out
