"""What every report is built of: its page (one self-contained HTML document), its tables and their cells, its
summary of a document's keys, its figures inline, and the PDF's pages of monospace text. The calibration report
(`service.reports.calibration`) and a robot tree's (`service.reports.tree`) both build from these, so a change to
how a number is shown shows in both."""

from __future__ import annotations

import html
from collections.abc import Mapping, Sequence
from typing import Any

from matplotlib.figure import Figure

from service.reports import figures

STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",sans-serif;margin:2rem auto;max-width:62rem;color:#222}
h1{font-size:1.5rem}h2{font-size:1.15rem;margin-top:2rem;border-bottom:1px solid #ddd}
table{border-collapse:collapse;font-size:.85rem}td,th{padding:.2rem .6rem;border-bottom:1px solid #eee;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums}.failed{color:#a00}.ok{color:#070}
figure{margin:1rem 0}svg{max-width:100%;height:auto}.note{background:#fff8e1;padding:.4rem .8rem}
"""


def page(title: str, body: str) -> str:
    """The HTML document: `title` as its title and heading, then `body`; its style inline (nothing fetched)."""
    return (
        f'<!DOCTYPE html><html lang="en"><head><meta charset="utf-8"><title>{html.escape(title)}</title>'
        f"<style>{STYLE}</style></head><body>"
        f"<h1>{html.escape(title)}</h1>{body}</body></html>"
    )


def cell(value: Any) -> str:
    """A value as a table shows it (HTML-escaped): a dash for none, yes/no, a float to 6 significant digits."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.6g}"
    return html.escape(str(value))


def data(value: Any) -> str:
    """The exact value, for machines reading the page (the browser test compares it with the API's)."""
    return html.escape(repr(value) if isinstance(value, float) else str(value), quote=True)


def table(headers: Sequence[str], rows: Sequence[Sequence[Any]], *, css: str = "") -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = "".join(
        "<tr>"
        + "".join(
            f'<td class="num">{cell(v)}</td>' if isinstance(v, int | float) else f"<td>{cell(v)}</td>" for v in row
        )
        + "</tr>"
        for row in rows
    )
    return f'<table class="{css}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def keyed_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], key: str) -> str:
    """A table whose numbers carry their exact value and key (`{key}.{label}.{column}`, the label the row's first
    cell) for machines; `key` is its class too."""
    head = "".join(f"<th>{html.escape(h)}</th>" for h in headers)
    body = []
    for row in rows:
        label = str(row[0])
        cells = [f"<td>{cell(label)}</td>"]
        for column, value in zip(headers[1:], row[1:], strict=True):
            where = f"{key}.{label}.{column}"
            cells.append(f'<td class="num" data-key="{data(where)}" data-value="{data(value)}">{cell(value)}</td>')
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f'<table class="{key}"><thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def dotted(document: Mapping[str, Any], key: str) -> Any:
    """The value at a dotted key of the document (None where any part is missing or null)."""
    value: Any = document
    for part in key.split("."):
        value = value.get(part) if isinstance(value, Mapping) else None
    return value


def summary_rows(document: Mapping[str, Any], labels: Sequence[tuple[str, str]]) -> list[tuple[str, str, Any]]:
    """(key, label, value) of each (dotted key, label) the document has a value for, in the order given."""
    rows = [(key, label, dotted(document, key)) for key, label in labels]
    return [r for r in rows if r[2] is not None]


def summary_table(rows: Sequence[tuple[str, str, Any]]) -> str:
    """The summary's (key, label, value) rows, each value keyed by its dotted key for machines."""
    body = "".join(
        f'<tr><th>{html.escape(label)}</th><td class="num" data-key="{key}" data-value="{data(value)}">'
        f"{cell(value)}</td></tr>"
        for key, label, value in rows
    )
    return f'<table class="summary">{body}</table>'


def figures_html(named: Sequence[tuple[str, Figure]]) -> str:
    """Each (name, figure) as inline SVG, its figure element's id `fig-<name>`."""
    return "".join(f'<figure id="fig-{name}">{figures.svg(fig)}</figure>' for name, fig in named)


def text_page(title: str, lines: Sequence[str]) -> Figure:
    """A PDF page of monospace text lines under a title."""
    fig = Figure(figsize=(8.27, 11.69))  # A4
    fig.text(0.08, 0.95, title, fontsize=14, weight="bold", va="top")
    fig.text(0.08, 0.91, "\n".join(lines), fontsize=8, va="top", family="monospace")
    return fig


def text_lines(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """A table as monospace text lines for a PDF page (html entities of `cell` undone)."""
    return [" | ".join(header), *(" | ".join(html.unescape(cell(v)) for v in row) for row in rows)]
