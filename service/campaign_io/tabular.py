"""A tolerant reader of campaign tables, as instrument software and spreadsheets write them.

What it accepts, because real files come that way: a UTF-8 byte-order mark (Excel), `,` `;` or tab as delimiter
(sniffed), decimal commas (European locales, with `;` or tab), `#` comment lines, blank lines, CR, LF or CRLF line
ends, columns in any order matched by name (case, spaces and a trailing unit such as `X [mm]` ignored; the unit
is read), unknown columns (named in a note, ignored). What it refuses, with the line and column: a cell that is
not a number, a missing column, a row with too many or too few cells, a body whose line breaks were stripped.
"""

from __future__ import annotations

import csv
import math
import re
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from service.campaign_io.errors import CampaignFileError, listed

DECIMAL_COMMA = re.compile(r"^[+-]?\d+,\d+(?:[eE][+-]?\d+)?$")
SNIFF_DELIMITERS = ",;\t"
SNIFF_LINES = 20
SNIFF_LINE_CHARS = 2048
"""What the delimiter sniffer sees: the header and SNIFF_LINES data lines, each cut to SNIFF_LINE_CHARS. The
sniffer's quote regex is quadratic in a line (`,"a,"a,"a…`: 6 000 characters 0.16 s, 12 000 0.69 s); a delimiter
shows in a line's first 2 kB, and when the cut lines disagree the header's most used delimiter decides."""


def _name_and_unit(name: str) -> tuple[str, str | None]:
    """`"X [mm]"` → `("X", "mm")`, `"Point ID"` → `("Point ID", None)`: a trailing `[unit]` or `(unit)` (either
    bracket may close either), the unit holding no closing bracket. By hand, in one pass: the lazy regex this
    replaces backtracked quadratically on a cell of `((((…` or of spaces (2 000 characters 0.09 s, 4 000 0.36 s).
    """
    text = name.strip()
    if not text.endswith(("]", ")")):
        return name, None
    inner = text[:-1]
    after_close = max(inner.rfind("]"), inner.rfind(")")) + 1  # the unit starts after any earlier closer
    opens = [i for i in (inner.find("[", after_close), inner.find("(", after_close)) if i >= 0]
    if not opens:
        return name, None
    start = min(opens)  # the leftmost opener: the name is as short as the old lazy match made it
    if inner[start + 1 :].strip().isdigit():
        return name, None  # Leica's `U(95)`: a number in brackets is part of the name, not a unit
    return text[:start].rstrip(), inner[start + 1 :]


UNIT_SUFFIXES = {"_rad": "rad", "_deg": "deg", "_mm": "mm"}
"""A unit written as the name's suffix (`joint_1_rad`, `x_mm`): as `[rad]`, `[mm]` would say."""


def _suffix_unit(core: str) -> tuple[str, str | None]:
    lowered = core.strip().lower()
    for suffix, unit in UNIT_SUFFIXES.items():
        if lowered.endswith(suffix) and len(lowered) > len(suffix):
            return core.strip()[: -len(suffix)], unit
    return core, None


def normalise(name: str) -> str:
    """`" X [mm] "` → `"x"`; `"Point ID"` → `"point_id"`."""
    core, unit = _name_and_unit(name)
    if unit is None:
        core = _suffix_unit(core)[0]
    core = re.sub(r"[\[\]()]", "", core)  # `U(95)` → `u95`
    return re.sub(r"[\s\-]+", "_", core.strip().lower())


def unit_of(name: str) -> str | None:
    core, unit = _name_and_unit(name)
    if unit is None:
        unit = _suffix_unit(core)[1]
    return unit.strip().lower() if unit is not None else None


@dataclass(frozen=True)
class Row:
    line: int
    """1-based line number in the file, for messages."""
    cells: Mapping[str, str]
    """Normalised column name → raw cell text."""


@dataclass(frozen=True)
class Table:
    columns: tuple[str, ...]
    """Normalised names, in file order."""
    units: Mapping[str, str]
    """Normalised name → unit given in the header (e.g. `x` → `m` for a column `X [m]`)."""
    rows: tuple[Row, ...]
    delimiter: str
    decimal_comma: bool
    notes: tuple[str, ...] = field(default=())
    length_unit: str | None = None
    """The length unit the file's preamble states (`Units: Millimeters`), for columns whose header states none."""

    def column_number(self, name: str) -> int:
        return self.columns.index(name) + 1

    def number(self, row: Row, name: str) -> float:
        """The cell as a float, or a CampaignFileError naming the line and column."""
        text = row.cells.get(name, "").strip()
        if self.decimal_comma:
            text = text.replace(",", ".")
        try:
            value = float(text)
        except ValueError:
            raise CampaignFileError(
                f"line {row.line}, column {self.column_number(name)} ({name}): {text!r} is not a number",
                line=row.line,
                column=self.column_number(name),
            ) from None
        if not math.isfinite(value):
            raise CampaignFileError(
                f"line {row.line}, column {self.column_number(name)} ({name}): {text!r} is not a finite number",
                line=row.line,
                column=self.column_number(name),
            )
        return value


def _content_lines(text: str, comment: str) -> list[tuple[int, str]]:
    lines = text.splitlines()  # universal: CR-only, LF, CRLF
    return [(k + 1, line) for k, line in enumerate(lines) if line.strip() and not line.lstrip().startswith(comment)]


def _sniff(header: str, sample: Sequence[str]) -> str:
    try:
        cut = [line[:SNIFF_LINE_CHARS] for line in (header, *sample[:SNIFF_LINES])]
        return csv.Sniffer().sniff("\n".join(cut), delimiters=SNIFF_DELIMITERS).delimiter
    except csv.Error:
        # The sniffer gives up on short or irregular samples: the delimiter the header uses most is the answer.
        counts = {d: header.count(d) for d in SNIFF_DELIMITERS}
        best = max(counts, key=lambda d: counts[d])
        return best if counts[best] else ","


def read_table(text: str, *, expected: Iterable[str] = (), comment: str = "#") -> Table:
    """Parse `text` into rows keyed by normalised header names. `expected` (normalised names) is only used to
    recognise a body whose line breaks were stripped and to word the messages."""
    text = text.removeprefix("\ufeff")
    lines = _content_lines(text, comment)
    if not lines:
        raise CampaignFileError("the file has no header and no data (only blank or comment lines)", line=1)
    skipped = _preamble(lines)
    preamble_unit = _stated_unit(t for _, t in lines[:skipped])
    lines = lines[skipped:]
    header_line, header = lines[0]
    expected_names = list(expected)
    widest = max(header.count(d) for d in SNIFF_DELIMITERS) + 1
    if len(lines) == 1 and expected_names and widest > 2 * len(expected_names):
        raise CampaignFileError(
            f"the body is a single line of {widest} fields: its line breaks were stripped (curl -d does that; "
            "send the file with curl --data-binary @file)",
            line=1,
        )
    data_lines = [t for _, t in lines[1:]]
    delimiter = _sniff(header, data_lines)
    parsed = _cells(lines, delimiter)
    raw_names = parsed[0]
    names = [normalise(n) for n in raw_names]
    if len(lines) == 1 and expected_names and len(names) > len(expected_names) + 1:
        raise CampaignFileError(
            f"the body is a single line of {len(names)} fields: its line breaks were stripped (curl -d does that; "
            "send the file with curl --data-binary @file)",
            line=1,
        )
    # Counted once (names.count per name was quadratic: 20 000 columns 6.1 s, 100 000 over 200 s).
    duplicates = sorted(n for n, times in Counter(names).items() if times > 1 and n)
    if duplicates:
        raise CampaignFileError(f"line {header_line}: columns {listed(duplicates)} appear twice", line=header_line)
    cells_rows = parsed[1:]
    decimal_comma = delimiter != "," and any(DECIMAL_COMMA.match(c.strip()) for r in cells_rows[:50] for c in r)
    rows = []
    for (line, _), cells in zip(lines[1:], cells_rows, strict=True):
        if len(cells) != len(names):
            raise CampaignFileError(
                f"line {line}: {len(cells)} cells for the {len(names)} columns of the header (delimiter {delimiter!r})",
                line=line,
            )
        rows.append(Row(line=line, cells=dict(zip(names, cells, strict=True))))
    units = {n: u for n, raw in zip(names, raw_names, strict=True) if (u := unit_of(raw))}
    return Table(
        columns=tuple(names),
        units=units,
        rows=tuple(rows),
        delimiter=delimiter,
        decimal_comma=decimal_comma,
        notes=_notes(skipped, preamble_unit, decimal_comma=decimal_comma),
        length_unit=preamble_unit,
    )


def _cells(lines: list[tuple[int, str]], delimiter: str) -> list[list[str]]:
    """Each content line's cells, one row a line: a CSV error or a quote left open names its line."""
    reader = csv.reader([t for _, t in lines], delimiter=delimiter)
    parsed: list[list[str]] = []
    try:
        for cells in reader:
            if reader.line_num != len(parsed) + 1:
                # A quote left open runs the cell on into the next lines (the csv module joins them), so rows and
                # lines no longer pair (found by tests/service/test_reader_fuzz.py: a 500).
                line = lines[len(parsed)][0]
                raise CampaignFileError(
                    f"line {line}: a quoted cell is not closed on its line (a '\"' without its pair)", line=line
                )
            parsed.append(cells)
    except csv.Error as exc:
        raise CampaignFileError(
            f"line {lines[reader.line_num - 1][0]}: {exc}", line=lines[reader.line_num - 1][0]
        ) from exc
    return parsed


def _notes(skipped: int, preamble_unit: str | None, *, decimal_comma: bool) -> tuple[str, ...]:
    notes = []
    if skipped:
        notes.append(
            f"{skipped} line(s) above the header read as the software's preamble"
            + (f" (its length unit: {preamble_unit})" if preamble_unit else "")
        )
    if decimal_comma:
        notes.append("numbers were read with decimal commas")
    return tuple(notes)


PREAMBLE_LINES = 30
"""At most this many lines of a report's preamble (title, part, date, units) before the header."""
PREAMBLE_FIELDS = 2
STATED_UNIT = re.compile(r"\bunits?\b\s*[:=]?\s*(millimet(?:er|re)s?|mm|met(?:er|re)s?|m|inch(?:es)?|in)\b", re.I)
UNIT_WORDS = {"millimeter": "mm", "millimetre": "mm", "meter": "m", "metre": "m", "inch": "in", "inche": "in"}


def _width(line: str) -> int:
    return max(line.count(d) for d in SNIFF_DELIMITERS) + 1


def _preamble(lines: Sequence[tuple[int, str]]) -> int:
    """How many leading lines are a report's preamble rather than the table: PC-DMIS, CAM2 and BuildIT reports
    open with lines such as `PART NAME : cell 3` or `Units: Millimeters` (one or two fields) before the header,
    and the header is the first line wider than that."""
    for k, (_, line) in enumerate(lines[: PREAMBLE_LINES + 1]):
        if _width(line) > PREAMBLE_FIELDS:
            return k
    return 0  # no line wider than a preamble's: a narrow table (a joint file of one joint), read as it is


def _stated_unit(preamble: Iterable[str]) -> str | None:
    """The length unit a preamble states (`Units: Millimeters`, `UNITS=MM`, `Unit: inch`), as MM_PER's key."""
    for line in preamble:
        found = STATED_UNIT.search(line)
        if found:
            word = found.group(1).lower().rstrip("s")
            return UNIT_WORDS.get(word, word)
    return None
