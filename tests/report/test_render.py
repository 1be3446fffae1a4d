"""The report's model and its two renderers: one model, the same sections in Markdown and HTML."""

from __future__ import annotations

import base64
import re

from omnislam.report.model import Figure, ReportModel, Section, with_unique_table_names
from omnislam.report.render import TABLES, render_html, render_markdown
from omnislam.report.tables import Num, make_table, to_csv, to_latex

SVG = '<?xml version="1.0"?>\n<svg xmlns="http://www.w3.org/2000/svg" width="10"></svg>'


def _model() -> ReportModel:
    table = make_table("a b", "Caption", ["estimator", "ATE"], [["ekfslam", Num("0.1", 0.1)]])
    sections = (
        Section("T & T", level=1),
        Section(
            "One",
            lead=("before <the> tables",),
            tables=(table,),
            paragraphs=("after | them",),
            figures=(Figure("one-kind.svg", "What? This.", SVG),),
            notes=("a note",),
        ),
        Section(None, paragraphs=("no heading",)),
    )
    return ReportModel("T & T", sections, {"ekfslam": "#123456"})


def test_markdown_renders_each_part_in_the_sections_order():
    assert render_markdown(_model()) == "\n".join(
        [
            "# T & T",
            "",
            "## One",
            "",
            "before <the> tables",
            "",
            "| estimator | ATE |",
            "|---|---|",
            "| ekfslam | 0.1 |",
            "",
            f"*Table as [CSV]({TABLES}/a-b.csv) · [LaTeX]({TABLES}/a-b.tex)*",
            "",
            "after | them",
            "",
            "![What? This.](one-kind.svg)",
            "",
            "*What? This.*",
            "",
            "- a note",
            "",
            "no heading",
            "",
        ]
    )


def test_html_renders_the_same_parts_escaped_with_swatches_and_inlined_figures():
    page = render_html(_model())
    assert page.startswith('<!DOCTYPE html>\n<html lang="en">')
    assert "<title>T &amp; T</title>" in page and "<h1>T &amp; T</h1>" in page
    body = page[page.index("<body>") :]
    order = ["<h2>One</h2>", "<p>before &lt;the&gt; tables</p>", "<table>", 'class="tables"',
             "<p>after | them</p>", "<figure><svg", 'class="note">a note</p>', "<p>no heading</p>"]
    positions = [body.index(part) for part in order]
    assert positions == sorted(positions)
    assert 'style="background:#123456"' in body  # the estimator named in a cell
    assert "<?xml" not in body  # the SVG is inlined as an element
    csv_link = re.search(r'download="a-b\.csv" href="data:text/csv;charset=utf-8;base64,([^"]+)"',
                         body)
    assert csv_link is not None
    assert base64.b64decode(csv_link.group(1)).decode() == to_csv(_model().tables[0])


def test_tables_of_one_name_are_numbered_in_report_order():
    first = make_table("a b", "A", ["x"], [["1"]])
    again = make_table("a-b", "B", ["x"], [["2"]])
    sections = with_unique_table_names(
        [Section("s", tables=(first,)), Section("t", tables=(again, first))]
    )
    names = [t.name for s in sections for t in s.tables]
    assert names == ["a-b", "a-b-2", "a-b-3"]
    assert "\\label{tab:a-b-2}" in to_latex(sections[1].tables[0])
    markdown = render_markdown(ReportModel("r", sections))
    assert f"({TABLES}/a-b-3.csv)" in markdown
