"""Comparative reports: ``report.md`` (+ SVGs next to it) and a self-contained ``index.html``.

``write_report(results_dir, out_dir)`` reads the results of ``omnislam compare`` (or a single
RUN_DIR, or a folder of RUN_DIRs: ``report.results``), builds the report once as a model of
sections (``report.model``, ``report.sections``) and renders it twice (``report.render``):

* a verdict per dataset (``metrics.verdict``: the best estimator by ATE RMSE, dead reckoning
  excluded, its margin over the next as medians over seeds, and whether that margin is within
  the seed spread),
* a headline table (datasets x estimators, ATE RMSE, each row naming its ground truth),
* per dataset: every estimator side by side with dead reckoning as the baseline (ATE, drift,
  RPE, landmark error, NEES, timing, memory; mean +- std over seeds: ``report.metric_tables``),
  then figures that answer one question each (``report.figures``, drawn by ``report.plots`` as
  SVG, inlined in the HTML),
* a provenance block (``report.provenance``: omnislam version and commit, date, command line,
  seeds, frames, images and path length of each dataset, each estimator's options, the
  machine),
* exports per cell (``exports/CELL/``: ``report.exports``): trajectory as TUM and KITTI, the
  landmark map as PLY (open3d, the ``render`` extra) and the factor graph as g2o when the run
  has one.

Every table is also written as ``tables/NAME.csv`` (full precision) and ``tables/NAME.tex``
(LaTeX ``booktabs``), linked under the table. Each estimator column has one colour
(``report.palette``) in every figure and, as a swatch before its name, in every HTML table.

The folder is written under a hidden name and renamed into place when complete.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from omnislam._files import check_output_location, output_error
from omnislam.errors import ConfigError
from omnislam.harness.rundir import make_shareable
from omnislam.report import palette
from omnislam.report.exports import write_exports
from omnislam.report.model import ReportModel, with_unique_table_names
from omnislam.report.options import ReportOptions
from omnislam.report.provenance import provenance_rows
from omnislam.report.render import TABLES, render_html, render_markdown
from omnislam.report.results import ReportCell, collect_cells, columns
from omnislam.report.sections import (
    dataset_sections,
    estimators_section,
    headline_section,
    left_out_section,
    notes_sections,
    provenance_section,
    summary_section,
    title_section,
    verdict_sections,
)
from omnislam.report.tables import to_csv, to_latex

REPORT_MD = "report.md"
REPORT_HTML = "index.html"


@dataclass(frozen=True, slots=True)
class ReportSummary:
    """What ``write_report`` wrote.

    Attributes:
        out_dir: the report folder.
        figures: the SVG file names of its figures, in report order.
        cells: how many runs it reports.
        notes: what could not be drawn or written, and why (the report's Notes).
    """

    out_dir: Path
    figures: tuple[str, ...]
    cells: int
    notes: tuple[str, ...] = field(default_factory=tuple)


def check_report_dir(out_dir: Path) -> None:
    """Refuse an existing non-empty folder that is not a report.

    Raises:
        ConfigError: naming the folder.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and (
        not out_dir.is_dir() or (any(out_dir.iterdir()) and not (out_dir / REPORT_MD).is_file())
    ):
        raise ConfigError(f"{out_dir}: exists and is not a report folder; refusing to overwrite it")
    check_output_location(out_dir, "report")


def write_report(
    results_dir: str | Path, out_dir: str | Path, options: ReportOptions | None = None
) -> ReportSummary:
    """Write ``report.md``, its SVGs, ``index.html``, the tables and the exports into
    ``out_dir``, atomically.

    Raises:
        DataError: ``results_dir`` is missing or malformed.
        ConfigError: ``out_dir`` exists and is not a report folder.
    """
    options = options or ReportOptions()
    out_dir = Path(out_dir)
    check_report_dir(out_dir)
    title, cells = collect_cells(results_dir)
    title = options.title or title
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(
            tempfile.mkdtemp(prefix=f".{out_dir.name}.", suffix=".tmp", dir=out_dir.parent)
        )
    except OSError as exc:
        raise output_error(exc, out_dir, "report") from None
    try:
        make_shareable(staging)
        notes: list[str] = []
        figure_names = _write_into(staging, Path(results_dir), title, cells, options, notes)
        if out_dir.exists():
            trash = out_dir.with_name(f".{out_dir.name}.old-{os.getpid()}")
            os.replace(out_dir, trash)
            os.replace(staging, out_dir)
            shutil.rmtree(trash, ignore_errors=True)
        else:
            os.replace(staging, out_dir)
    except OSError as exc:
        shutil.rmtree(staging, ignore_errors=True)
        raise output_error(exc, out_dir, "report", atomic=True) from None
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return ReportSummary(out_dir, tuple(figure_names), len(cells), tuple(notes))


def _write_into(
    out: Path,
    results_dir: Path,
    title: str,
    cells: Sequence[ReportCell],
    options: ReportOptions,
    notes: list[str],
) -> list[str]:
    """Build the report's model, write the exports, tables and figures, render it twice.

    Returns:
        The figures' file names, in report order.
    """
    made = provenance_rows(results_dir, title, cells, options)
    colours = palette.colours(columns(cells))
    body = [
        title_section(title),
        *verdict_sections(cells, dict(made)),
        headline_section(cells),
        *summary_section(cells, colours, options),
        *dataset_sections(cells, colours, options, notes),
    ]
    if options.exports:
        _write_exports(out, cells, options, notes)
    tail = [
        left_out_section(options),
        *notes_sections(notes),
        estimators_section(cells),
        provenance_section(made),
    ]
    model = ReportModel(title, with_unique_table_names([*body, *tail]), colours)
    _write_tables(out / TABLES, model)
    for figure in model.figures:
        (out / figure.name).write_text(figure.svg)
    (out / REPORT_MD).write_text(render_markdown(model))
    (out / REPORT_HTML).write_text(render_html(model))
    return [figure.name for figure in model.figures]


def _write_exports(
    out: Path, cells: Sequence[ReportCell], options: ReportOptions, notes: list[str]
) -> None:
    """``exports/`` (``report.exports``), after every dataset's figures."""
    datasets = len(dict.fromkeys(c.dataset for c in cells))
    if options.on_step is not None:
        options.on_step("exports", datasets, datasets)
    write_exports(out, cells, notes)


def _write_tables(folder: Path, model: ReportModel) -> None:
    """Every table of the report as ``NAME.csv`` and ``NAME.tex`` in ``folder``."""
    folder.mkdir()
    for table in model.tables:
        (folder / f"{table.name}.csv").write_text(to_csv(table))
        (folder / f"{table.name}.tex").write_text(to_latex(table))
