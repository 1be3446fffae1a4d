"""The report as a model: typed sections built once, rendered to Markdown and to HTML.

A ``ReportModel`` is the report's title, its estimator colours and its ``Section``s in order;
``render.render_markdown`` and ``render.render_html`` turn the same model into ``report.md``
and ``index.html``, so the two never say different things. A section renders its parts in one
order: heading, lead paragraphs, tables, paragraphs, figures, notes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from omnislam.report.tables import Table


@dataclass(frozen=True, slots=True)
class Figure:
    """One figure of the report.

    Attributes:
        name: its SVG file name next to ``report.md`` (``DATASET-KIND.svg``).
        caption: what it shows, as the question it answers.
        svg: the SVG document (also inlined in the HTML).
    """

    name: str
    caption: str
    svg: str


@dataclass(frozen=True, slots=True)
class Section:
    """One section of the report.

    Attributes:
        title: its heading; None continues the section before it (no heading).
        level: the heading's level (1: the report's title; default 2).
        lead: paragraphs before the tables.
        tables: tables (each also written as ``tables/NAME.csv`` and ``.tex``, linked under it).
        paragraphs: paragraphs after the tables.
        figures: figures after the paragraphs.
        notes: remarks, one per item (a list in Markdown, notes in HTML).
    """

    title: str | None
    level: int = 2
    lead: tuple[str, ...] = ()
    tables: tuple[Table, ...] = ()
    paragraphs: tuple[str, ...] = ()
    figures: tuple[Figure, ...] = ()
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class ReportModel:
    """A whole report.

    Attributes:
        title: the report's title (its first section is the level-1 heading of it).
        sections: every section in order.
        colours: estimator column -> colour (``palette``), the swatches of the HTML tables.
    """

    title: str
    sections: tuple[Section, ...]
    colours: Mapping[str, str] = field(default_factory=dict)

    @property
    def tables(self) -> tuple[Table, ...]:
        """Every table, in report order."""
        return tuple(t for s in self.sections for t in s.tables)

    @property
    def figures(self) -> tuple[Figure, ...]:
        """Every figure, in report order."""
        return tuple(f for s in self.sections for f in s.figures)


def with_unique_table_names(sections: Sequence[Section]) -> tuple[Section, ...]:
    """The sections with every table named once: a name met again becomes ``NAME-2``,
    ``NAME-3``, ... in report order (one ``tables/NAME.csv`` per table)."""
    taken: set[str] = set()

    def unique(table: Table) -> Table:
        name, k = table.name, 2
        while name in taken:
            name, k = f"{table.name}-{k}", k + 1
        taken.add(name)
        return table if name == table.name else replace(table, name=name)

    return tuple(replace(s, tables=tuple(unique(t) for t in s.tables)) for s in sections)
