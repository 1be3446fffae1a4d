"""The report's tables, written three ways: Markdown/HTML (in the report), CSV and LaTeX.

A ``Table`` holds the text shown in the report and, for each cell, the exact numbers behind
it (``Num``). ``to_csv`` writes the numbers at full precision (a cell summarising seeds -- the
median with its min-max range -- becomes a column and ``min`` and ``max`` columns next to it);
``to_latex`` writes a ``booktabs`` table of the text shown, with LaTeX's special characters
escaped.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class Num:
    """A number as the report shows it (``text``) and as the CSV writes it.

    Attributes:
        text: what the tables show, e.g. ``"0.052 [0.049–0.060]"`` or ``"–"``.
        value: the number (the median over seeds), None when there is none.
        low, high: the smallest and largest value over seeds, None when no spread is known
            (one run, a deterministic estimator, or no value).
    """

    text: str
    value: float | None = None
    low: float | None = None
    high: float | None = None

    def __str__(self) -> str:
        return self.text

    @property
    def has_range(self) -> bool:
        return self.low is not None and self.high is not None


#: one cell of a table
Cell = str | Num


@dataclass(frozen=True, slots=True)
class Table:
    """One table of the report.

    Attributes:
        name: file stem of ``tables/NAME.csv`` and ``tables/NAME.tex`` (letters, digits, ``-_``).
        caption: the LaTeX caption.
        header: column names.
        rows: the cells, one list per row.
        csv_header, csv_rows: the CSV when it is not derived from the cells (e.g. a range shown
            as ``a–b`` written as two columns).
    """

    name: str
    caption: str
    header: tuple[str, ...]
    rows: tuple[tuple[Cell, ...], ...]
    csv_header: tuple[str, ...] | None = None
    csv_rows: tuple[tuple[object, ...], ...] | None = field(default=None)

    @property
    def text_rows(self) -> list[list[str]]:
        return [[str(c) for c in row] for row in self.rows]


def make_table(
    name: str,
    caption: str,
    header: Sequence[str],
    rows: Sequence[Sequence[Cell]],
    csv_header: Sequence[str] | None = None,
    csv_rows: Sequence[Sequence[object]] | None = None,
) -> Table:
    return Table(
        slug(name),
        caption,
        tuple(header),
        tuple(tuple(r) for r in rows),
        tuple(csv_header) if csv_header is not None else None,
        tuple(tuple(r) for r in csv_rows) if csv_rows is not None else None,
    )


def slug(text: str) -> str:
    """A file-name-safe form of ``text``."""
    out = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in text)
    while "--" in out:
        out = out.replace("--", "-")
    return out.strip("-") or "table"


def _csv_value(value: object) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def _cell_text(cell: Cell) -> str:
    return "" if str(cell) == "–" else str(cell)


def csv_grid(table: Table) -> tuple[list[str], list[list[str]]]:
    """(header, rows) of the table's CSV."""
    if table.csv_header is not None and table.csv_rows is not None:
        return list(table.csv_header), [[_csv_value(v) for v in r] for r in table.csv_rows]
    with_range = [
        any(isinstance(row[j], Num) and row[j].has_range for row in table.rows)  # type: ignore[union-attr]
        for j in range(len(table.header))
    ]
    header: list[str] = []
    for name, ranged in zip(table.header, with_range, strict=True):
        header += [name, f"{name} min", f"{name} max"] if ranged else [name]
    rows = []
    for row in table.rows:
        out: list[str] = []
        for cell, ranged in zip(row, with_range, strict=True):
            if isinstance(cell, Num):
                out.append(_csv_value(cell.value) if cell.value is not None else _cell_text(cell))
                if ranged:
                    out += [_csv_value(cell.low), _csv_value(cell.high)]
            else:
                out.append(_cell_text(cell))
                if ranged:
                    out += ["", ""]
        rows.append(out)
    return header, rows


def to_csv(table: Table) -> str:
    """The table as CSV (numbers at full precision, empty where the report shows '–')."""
    header, rows = csv_grid(table)
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows(rows)
    return buffer.getvalue()


_LATEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "&": r"\&",
    "%": r"\%",
    "$": r"\$",
    "#": r"\#",
    "_": r"\_",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "±": r"$\pm$",
    "–": "--",
    "—": "---",
    "×": r"$\times$",
    "≤": r"$\leq$",
    "≥": r"$\geq$",
    "<": r"\textless{}",
    ">": r"\textgreater{}",
}


def latex_escape(text: str) -> str:
    """``text`` with LaTeX's special characters escaped (and ±, en/em dashes as LaTeX)."""
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in text)


def to_latex(table: Table) -> str:
    """The table as a ``booktabs`` ``tabular`` inside a ``table`` float (needs
    ``\\usepackage{booktabs}``)."""
    spec = "l" + "r" * (len(table.header) - 1)
    lines = [
        "% generated by omnislam report; needs \\usepackage{booktabs}",
        "\\begin{table}[htbp]",
        "\\centering",
        f"\\caption{{{latex_escape(table.caption)}}}",
        f"\\label{{tab:{table.name}}}",
        f"\\begin{{tabular}}{{{spec}}}",
        "\\toprule",
        " & ".join(latex_escape(h) for h in table.header) + " \\\\",
        "\\midrule",
    ]
    lines += [" & ".join(latex_escape(c) for c in row) + " \\\\" for row in table.text_rows]
    lines += ["\\bottomrule", "\\end{tabular}", "\\end{table}", ""]
    return "\n".join(lines)
