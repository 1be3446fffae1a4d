"""The report's two renderers: ``render_markdown`` (``report.md``) and ``render_html``
(``index.html``, self-contained: figures inlined, each table's CSV and LaTeX as data links).

Both walk the same ``model.ReportModel``, section by section in the order ``model.Section``
states; in HTML an estimator named in a table cell gets a swatch of its colour (``palette``).
"""

from __future__ import annotations

import base64
import html
from collections.abc import Mapping, Sequence

from omnislam.report.model import ReportModel, Section
from omnislam.report.tables import Cell, Table, to_csv, to_latex

#: folder of the CSV and LaTeX copies of every table, next to report.md
TABLES = "tables"

_CSS = """
body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:.9em;max-width:100%}
th,td{border:1px solid #ccc;padding:.3em .5em;text-align:right;overflow-wrap:break-word}
th{font-size:.9em;vertical-align:bottom}
th:first-child,td:first-child{text-align:left}
thead{background:#f0f0f0} img{max-width:100%} figure{margin:1.5em 0}
figure svg{display:block;max-width:100%;height:auto}
figcaption{font-size:.9em;color:#444;max-width:60em}
.note{color:#844} .tables{font-size:.8em;margin-top:-.6em} .estimator{white-space:nowrap}
.swatch{display:inline-block;width:.8em;height:.8em;margin-right:.35em;vertical-align:-.05em;
border:1px solid rgba(0,0,0,.25)}
"""


def render_markdown(model: ReportModel) -> str:
    """``report.md``: headings, paragraphs, pipe tables with links to their CSV and LaTeX,
    figures as images of their SVG files with the caption under them, notes as a list."""
    lines: list[str] = []
    for section in model.sections:
        lines += _markdown_section(section)
    return "\n".join(lines)


def render_html(model: ReportModel) -> str:
    """``index.html``: one self-contained page of the same sections (figures inlined)."""
    body: list[str] = []
    for section in model.sections:
        body += _html_section(section, model.colours)
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(model.title)}</title><style>{_CSS}</style></head><body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )


# -- Markdown --------------------------------------------------------------------------------


def _markdown_section(section: Section) -> list[str]:
    lines: list[str] = []
    if section.title is not None:
        lines += ["#" * section.level + " " + section.title, ""]
    for text in section.lead:
        lines += [text, ""]
    for table in section.tables:
        name = table.name
        lines += [
            _markdown_table(table.header, table.rows),
            "",
            f"*Table as [CSV]({TABLES}/{name}.csv) · [LaTeX]({TABLES}/{name}.tex)*",
            "",
        ]
    for text in section.paragraphs:
        lines += [text, ""]
    for figure in section.figures:
        lines += [f"![{figure.caption}]({figure.name})", "", f"*{figure.caption}*", ""]
    if section.notes:
        lines += [f"- {note}" for note in section.notes] + [""]
    return lines


def _md_cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _markdown_table(header: Sequence[str], rows: Sequence[Sequence[Cell]]) -> str:
    lines = ["| " + " | ".join(map(_md_cell, header)) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(map(_md_cell, r)) + " |" for r in rows]
    return "\n".join(lines)


# -- HTML ------------------------------------------------------------------------------------


def _html_section(section: Section, colours: Mapping[str, str]) -> list[str]:
    out: list[str] = []
    if section.title is not None:
        level = section.level
        out.append(f"<h{level}>{html.escape(section.title)}</h{level}>")
    out += [f"<p>{html.escape(text)}</p>" for text in section.lead]
    for table in section.tables:
        out.append(_html_table(table.header, table.rows, colours))
        out.append(_html_table_links(table))
    out += [f"<p>{html.escape(text)}</p>" for text in section.paragraphs]
    if section.figures:
        from omnislam.report.plots import inline_svg

        out += [
            f"<figure>{inline_svg(figure.svg, figure.caption)}"
            f"<figcaption>{html.escape(figure.caption)}</figcaption></figure>"
            for figure in section.figures
        ]
    out += [f'<p class="note">{html.escape(note)}</p>' for note in section.notes]
    return out


def _html_table_links(table: Table) -> str:
    """The table's CSV and LaTeX as download links (data URLs) and where their files are."""
    name = table.name
    links = " · ".join(
        f'<a download="{name}.{ext}" href="data:{mime};charset=utf-8;base64,'
        f'{base64.b64encode(text.encode()).decode("ascii")}">{label}</a>'
        for ext, mime, label, text in (
            ("csv", "text/csv", "CSV", to_csv(table)),
            ("tex", "application/x-tex", "LaTeX", to_latex(table)),
        )
    )
    return (
        f'<p class="tables">Table as {links} (also {TABLES}/{html.escape(name)}.csv and '
        f".tex next to report.md)</p>"
    )


def _html_cell(value: Cell, colours: Mapping[str, str]) -> str:
    """A cell's text, after a swatch of the estimator's colour when it names one."""
    text = str(value)
    colour = colours.get(text)
    if not colour:
        return html.escape(text)
    swatch = f'<span class="swatch" style="background:{colour}" title="{colour}"></span>'
    return f'<span class="estimator">{swatch}{html.escape(text)}</span>'


def _html_table(
    header: Sequence[str], rows: Sequence[Sequence[Cell]], colours: Mapping[str, str]
) -> str:
    head = "".join(f"<th>{_html_cell(h, colours)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{_html_cell(v, colours)}</td>" for v in row) + "</tr>"
        for row in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"
