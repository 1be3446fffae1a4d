"""Comparative reports: ``report.md`` (+ SVGs next to it) and a self-contained ``index.html``.

``write_report(results_dir, out_dir)`` reads the results of ``omnislam compare`` (or a single
RUN_DIR, or a folder of RUN_DIRs), and writes:

* a headline table (datasets x estimators, ATE RMSE, each row naming its ground truth),
* per dataset: every estimator side by side with dead reckoning as the baseline (ATE, drift,
  RPE, landmark error, NEES, timing, memory; mean +- std over seeds), then figures that answer
  one question each (``FIGURES``, drawn by ``report.plots`` as SVG, inlined in the HTML): ATE
  over seeds, accuracy against run time, each trajectory coloured by its position error over
  the ground truth, error over distance, landmark maps, step-time percentiles and -- where the
  data has laser scans (CARMEN) -- occupancy grids built from the scans on every estimated
  trajectory (``report.occupancy``),
* exports per cell (``exports/CELL/``): trajectory as TUM and KITTI, the landmark map as PLY
  (open3d, the ``render`` extra) and the factor graph as g2o when the run has one.

It opens with a verdict per dataset (``metrics.verdict``: the best estimator by ATE RMSE, dead
reckoning excluded, its margin over the next as medians over seeds, and whether that margin is
within the seed spread) and ends with a provenance block (``report.provenance``: omnislam
version and commit, date, command line, seeds, frames, images and path length of each dataset, each
estimator's options, the machine). Every table is also written as ``tables/NAME.csv`` (full
precision) and ``tables/NAME.tex`` (LaTeX ``booktabs``), linked under the table.

Each estimator column has one colour (``report.palette``) in every figure and, as a swatch
before its name, in every HTML table.

The folder is written under a hidden name and renamed into place when complete.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from omnislam._files import check_output_location, output_error
from omnislam.datasets.registry import DatasetFormat
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import ConfigError, DataError, MissingExtraError, OmnislamError
from omnislam.harness.evaluation import GROUND_TRUTH_LABELS, evaluate_run
from omnislam.harness.layout import (
    CELLS,
    CONFIG,
    ESTIMATOR_INFO,
    GRAPH_G2O,
    GRID_COPY,
    METRICS,
    RESULTS_JSON,
)
from omnislam.harness.rundir import (
    RunConfig,
    RunRecord,
    make_shareable,
    read_run_config,
    read_run_dir,
)
from omnislam.metrics.metrics import Alignment, AteResult, ate
from omnislam.metrics.run_metrics import RunMetrics, read_run_metrics
from omnislam.metrics.verdict import Verdict, verdict
from omnislam.report import palette, provenance
from omnislam.report.tables import Cell, Num, Table, make_table, slug, to_csv, to_latex

REPORT_MD = "report.md"
REPORT_HTML = "index.html"
#: folder of the CSV and LaTeX copies of every table
TABLES = "tables"
#: estimator name of the baseline column
BASELINE = "deadreckoning"
#: dataset formats whose Sequence can carry raw laser scans (occupancy grids)
LASER_FORMATS = (DatasetFormat.CARMEN, DatasetFormat.SYNTHETIC)


@dataclass(frozen=True, slots=True)
class ReportCell:
    """One run as the report sees it.

    Attributes:
        cell_id: folder name of the run.
        dataset: dataset label.
        column: estimator label (with override) -- one column of the tables.
        estimator: estimator name.
        seed: the run's seed.
        status: ``computed`` / ``reused`` / ``failed`` (runner) or ``run`` (a plain RUN_DIR).
        error: why it failed.
        metrics: its metrics (None when failed).
        run_dir: where the RUN_DIR is (None when failed).
    """

    cell_id: str
    dataset: str
    column: str
    estimator: str
    seed: int | None
    status: str
    error: str | None = None
    metrics: RunMetrics | None = None
    run_dir: Path | None = None

    @property
    def ok(self) -> bool:
        return self.metrics is not None and self.run_dir is not None


@dataclass(frozen=True, slots=True)
class ReportOptions:
    """What to include.

    Attributes:
        title: the report's title (default: the grid's name).
        exports: write ``exports/CELL/`` (TUM, KITTI, PLY, g2o).
        figures: draw each dataset's figures (False: verdicts and tables only -- a report of
            many datasets small enough to commit, e.g. the suite's).
        occupancy: build occupancy grids where the data has laser scans.
        occupancy_resolution_m: grid cell size [m].
        command: the command line recorded in the provenance block (default: ``sys.argv``).
        on_step: progress: called with (stage, done, total) as the report is written
            ("figures": datasets done of total, "exports": runs done of total).
    """

    title: str | None = None
    exports: bool = True
    figures: bool = True
    occupancy: bool = True
    occupancy_resolution_m: float = 0.1
    command: tuple[str, ...] | None = None
    on_step: Callable[[str, int, int], None] | None = None


@dataclass(frozen=True, slots=True)
class ReportSummary:
    """What ``write_report`` wrote."""

    out_dir: Path
    figures: tuple[str, ...]
    cells: int
    notes: tuple[str, ...] = field(default_factory=tuple)


# --------------------------------------------------------------------------------------------
# Reading results
# --------------------------------------------------------------------------------------------


def _cell_from_run_dir(path: Path, status: str = "run") -> ReportCell:
    record = read_run_dir(path)
    if (path / METRICS).is_file():
        metrics = read_run_metrics(path / METRICS)
    else:  # not evaluated yet: evaluate in memory (the user's folder is left untouched)
        metrics = evaluate_run(record)
    config = record.config
    options = dict(config.estimator_options)
    column = config.estimator + (
        f" [{','.join(f'{k}={v}' for k, v in sorted(options.items()))}]" if options else ""
    )
    return ReportCell(
        cell_id=path.name,
        dataset=config.dataset if "/" not in config.dataset else Path(config.dataset).name,
        column=column,
        estimator=config.estimator,
        seed=config.seed,
        status=status,
        metrics=metrics,
        run_dir=path,
    )


#: statuses a row of results.json can have (``runner.CellStatus``)
ROW_STATUSES = ("computed", "reused", "failed")
#: keys of a row of results.json that are text, and those that may also be null
_ROW_TEXT = ("cell", "dataset", "column", "estimator", "status")
_ROW_OPTIONAL = {"error": str, "metrics": dict}


def _check_cell_row(row: object, number: int, path: Path) -> None:
    """One row of ``results.json`` against the types the runner writes.

    Raises:
        DataError: naming the file, the row (``cells[k]``) and the key: not a mapping, a missing
            or non-text label, a cell that is not a plain folder name, a seed that is not an
            integer, an unknown status, an error that is not text or metrics not a mapping.
    """

    def bad(message: str) -> DataError:
        return DataError(f"malformed cell row cells[{number}]: {message}", path)

    if not isinstance(row, dict):
        raise bad(f"must be a mapping, got {type(row).__name__}")
    for key in _ROW_TEXT:
        if not isinstance(row.get(key), str) or not row[key]:
            raise bad(f"{key!r} must be text, got {row.get(key)!r}")
    if Path(row["cell"]).name != row["cell"] or row["cell"] in (".", ".."):
        raise bad(f"'cell' must be a folder name of cells/, got {row['cell']!r}")
    seed = row.get("seed")
    if seed is not None and (not isinstance(seed, int) or isinstance(seed, bool)):
        raise bad(f"'seed' must be an integer or null, got {seed!r}")
    if row["status"] not in ROW_STATUSES:
        raise bad(f"'status' must be one of {', '.join(ROW_STATUSES)}, got {row['status']!r}")
    for key, kind in _ROW_OPTIONAL.items():
        if row.get(key) is not None and not isinstance(row[key], kind):
            raise bad(
                f"{key!r} must be {'text' if kind is str else 'a mapping'} or null, got "
                f"{type(row[key]).__name__}"
            )


def collect_cells(results_dir: str | Path) -> tuple[str, list[ReportCell]]:
    """Read what a report is made of.

    Args:
        results_dir: RESULTS_DIR of ``omnislam compare`` (has ``results.json``), a RUN_DIR, or
            a folder whose sub-folders are RUN_DIRs.

    Returns:
        (title, cells).

    Raises:
        DataError: the folder is missing or none of the above, or a file in it is malformed.
    """
    root = Path(results_dir)
    if not root.is_dir():
        raise DataError("no such folder", root)
    if (root / RESULTS_JSON).is_file():
        try:
            summary = json.loads((root / RESULTS_JSON).read_text())
        except (OSError, ValueError) as exc:
            raise DataError(f"malformed results file ({exc})", root / RESULTS_JSON) from exc
        if not isinstance(summary, dict) or "cells" not in summary:
            raise DataError("malformed results file (no 'cells' list)", root / RESULTS_JSON)
        rows, grid = summary["cells"], summary.get("grid")
        if grid is not None and not isinstance(grid, str):
            raise DataError(
                f"malformed results file ('grid' must be text, got {type(grid).__name__})",
                root / RESULTS_JSON,
            )
        title = grid or root.name
        if not isinstance(rows, list):
            raise DataError(
                f"malformed results file ('cells' must be a list, got {type(rows).__name__})",
                root / RESULTS_JSON,
            )
        cells = []
        for number, row in enumerate(rows):
            _check_cell_row(row, number, root / RESULTS_JSON)
            try:
                run_dir = root / CELLS / row["cell"]
                ok = row["status"] != "failed" and (run_dir / CONFIG).is_file()
                metrics = read_run_metrics(run_dir / METRICS) if ok else None
                cells.append(
                    ReportCell(
                        cell_id=row["cell"],
                        dataset=row["dataset"],
                        column=row["column"],
                        estimator=row["estimator"],
                        seed=row["seed"],
                        status=row["status"],
                        error=row.get("error"),
                        metrics=metrics,
                        run_dir=run_dir if ok else None,
                    )
                )
            except (KeyError, TypeError) as exc:
                raise DataError(f"malformed cell row ({exc})", root / RESULTS_JSON) from exc
        return title, cells
    if (root / CONFIG).is_file():
        return root.name, [_cell_from_run_dir(root)]
    runs = sorted(p for p in root.iterdir() if (p / CONFIG).is_file())
    if not runs:
        raise DataError(
            "not a results folder of `omnislam compare` (no results.json), not a RUN_DIR and "
            "holds no RUN_DIRs",
            root,
        )
    return root.name, [_cell_from_run_dir(p) for p in runs]


# --------------------------------------------------------------------------------------------
# Tables
# --------------------------------------------------------------------------------------------


#: one number of a run's metrics (None when it has none)
Metric = Callable[[RunMetrics], float | int | None]


def _values(cells: Sequence[ReportCell], metric: Metric) -> list[float]:
    """``metric`` of every cell that has metrics and a value for it."""
    values = (metric(c.metrics) for c in cells if c.metrics is not None)
    return [float(v) for v in values if v is not None]


def _fmt(values: Sequence[float], digits: int = 3) -> str:
    if not values:
        return "–"
    mean = float(np.mean(values))
    text = f"{mean:.{digits}g}"
    spread = float(np.std(values, ddof=1)) if len(values) > 1 else 0.0
    if spread > 0:
        text += f" ± {spread:.2g}"
    return text


def _num(values: Sequence[float], digits: int = 3) -> Num:
    """``_fmt`` of the values, keeping their mean and standard deviation for the CSV."""
    if not values:
        return Num("–")
    std = float(np.std(values, ddof=1)) if len(values) > 1 else None
    return Num(_fmt(values, digits), float(np.mean(values)), std)


def _columns(cells: Sequence[ReportCell]) -> list[str]:
    """Column labels with the baseline first, then in grid order."""
    columns = list(dict.fromkeys(c.column for c in cells))
    return sorted(columns, key=lambda col: col != BASELINE)


def _gt_label(cells: Sequence[ReportCell]) -> str:
    for c in cells:
        if c.metrics is not None:
            return GROUND_TRUTH_LABELS[c.metrics.ground_truth.kind]
    return "unknown ground truth"


def _ate_rmse(m: RunMetrics) -> float | None:
    return m.ate.rmse_m


#: the columns of a dataset's table: header and the metric it averages over seeds (None: the
#: ratio to dead reckoning, matched / estimated landmarks and the number of runs)
DETAIL_COLUMNS: tuple[tuple[str, Metric | None], ...] = (
    ("ATE RMSE [m]", _ate_rmse),
    ("ATE / dead reckoning", None),
    ("ATE max [m]", lambda m: m.ate.max_m),
    ("drift: ATE origin-aligned RMSE [m]", lambda m: m.ate.origin_rmse_m),
    ("RPE trans RMSE [m]", lambda m: m.rpe.trans_rmse_m),
    ("RPE rot RMSE [deg]", lambda m: m.rpe.rot_rmse_deg),
    ("landmark RMSE [m]", lambda m: m.landmarks.rmse_m),
    ("landmarks matched / estimated", None),
    ("pose NEES (dof 3)", lambda m: m.nees.pose_mean),
    ("step median [ms]", lambda m: m.timing.step_median_ms),
    ("step p95 [ms]", lambda m: m.timing.step_p95_ms),
    ("total [s]", lambda m: m.timing.total_s),
    ("peak RSS [MB]", lambda m: m.timing.peak_rss_mb),
    ("runs", None),
)


def _detail_rows(cells: Sequence[ReportCell]) -> tuple[list[str], list[list[Cell]]]:
    header = ["estimator", *(name for name, _ in DETAIL_COLUMNS)]
    by_column = {col: [c for c in cells if c.column == col] for col in _columns(cells)}
    baseline = _values([c for c in cells if c.column == BASELINE and c.ok], _ate_rmse)
    rows = []
    for column, group in by_column.items():
        ok = [c for c in group if c.ok]
        row: list[Cell] = [column]
        for name, metric in DETAIL_COLUMNS:
            if metric is not None:
                row.append(_num(_values(ok, metric)))
            elif name.startswith("ATE /"):
                ate_values = _values(ok, _ate_rmse)
                if ate_values and baseline and np.mean(baseline) > 0:
                    ratio = float(np.mean(ate_values) / np.mean(baseline))
                    row.append(Num(f"{ratio:.2f}x", ratio))
                else:
                    row.append(Num("–"))
            elif name.startswith("landmarks"):
                matched = _values(ok, lambda m: m.landmarks.matched)
                estimated = _values(ok, lambda m: m.landmarks.estimated)
                row.append(f"{_fmt(matched)} / {_fmt(estimated)}" if any(estimated) else "–")
            else:
                failed = len(group) - len(ok)
                row.append(
                    Num(f"{len(ok)} ({failed} failed)") if failed else Num(f"{len(ok)}", len(ok))
                )
        rows.append(row)
    return header, rows


#: the association decisions an estimator's ``estimator_info.json`` may count, by the report's
#: column: the first of the keys that the record holds (graphslam, EKF-SLAM's range-bearing and
#: omni filters, FastSLAM name them differently)
ASSOCIATION_COUNTS: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("landmarks", ("landmarks",)),
    ("created", ("landmarks_created", "created")),
    ("associated", ("sightings_associated", "associated")),
    ("ambiguous", ("sightings_ambiguous", "ambiguous")),
    ("gated (rejected)", ("sightings_gated", "gated")),
    ("tentative dropped", ("tentative_dropped",)),
    ("merged", ("landmarks_merged",)),
    ("loop closures", ("loop_closures",)),
)


def association_rows(cells: Sequence[ReportCell]) -> tuple[list[str], list[list[Cell]]]:
    """One row per run whose ``estimator_info.json`` counts association decisions (the
    ``ASSOCIATION_COUNTS`` besides ``landmarks``; none: no rows), in the cells' order."""
    header = ["estimator", "seed", *(name for name, _ in ASSOCIATION_COUNTS)]
    rows: list[list[Cell]] = []
    for cell in cells:
        if not cell.ok or cell.run_dir is None or not (cell.run_dir / ESTIMATOR_INFO).is_file():
            continue
        try:
            info = json.loads((cell.run_dir / ESTIMATOR_INFO).read_text())
        except (OSError, ValueError) as exc:
            raise DataError(f"{cell.run_dir / ESTIMATOR_INFO}: not readable JSON ({exc})") from exc
        values = [next((info[k] for k in keys if isinstance(info.get(k), int)), None)
                  for _, keys in ASSOCIATION_COUNTS]
        if all(v is None for v in values[1:]):
            continue
        rows.append([cell.column, "–" if cell.seed is None else str(cell.seed),
                     *(Num("–") if v is None else Num(str(v), v) for v in values)])
    return header, rows


def _md_cell(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _markdown_table(header: Sequence[str], rows: Sequence[Sequence[Cell]]) -> str:
    lines = ["| " + " | ".join(map(_md_cell, header)) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(map(_md_cell, r)) + " |" for r in rows]
    return "\n".join(lines)


def _html_cell(value: Cell, colours: Mapping[str, str]) -> str:
    """A cell's text, after a swatch of the estimator's colour when it names one."""
    text = str(value)
    colour = colours.get(text)
    if not colour:
        return html.escape(text)
    swatch = f'<span class="swatch" style="background:{colour}" title="{colour}"></span>'
    return f'<span class="estimator">{swatch}{html.escape(text)}</span>'


def _html_table(
    header: Sequence[str],
    rows: Sequence[Sequence[Cell]],
    colours: Mapping[str, str] | None = None,
) -> str:
    colours = colours or {}
    head = "".join(f"<th>{_html_cell(h, colours)}</th>" for h in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{_html_cell(v, colours)}</td>" for v in row) + "</tr>"
        for row in rows
    )
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


# --------------------------------------------------------------------------------------------
# Verdict and provenance
# --------------------------------------------------------------------------------------------


def _is_baseline(cells: Sequence[ReportCell], column: str) -> bool:
    return column == BASELINE or any(c.column == column and c.estimator == BASELINE for c in cells)


def dataset_verdicts(cells: Sequence[ReportCell]) -> list[Verdict]:
    """The verdict of each dataset (``metrics.verdict``), in the order of the cells."""
    out = []
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        out.append(
            verdict(
                dataset,
                _gt_label(group),
                _columns(group),
                lambda col, g=group: _values([c for c in g if c.column == col and c.ok], _ate_rmse),
                lambda col, g=group: _is_baseline(g, col),
            )
        )
    return out


def _range_text(low: float, high: float, seeds: int) -> str:
    return f"{low:.3g}–{high:.3g}" if seeds > 1 else f"{low:.3g} (1 seed)"


def verdict_table(verdicts: Sequence[Verdict]) -> Table:
    header = (
        "dataset",
        "best",
        "ATE RMSE median [m]",
        "min–max [m]",
        "seeds",
        "runner-up",
        "runner-up median [m]",
        "runner-up min–max [m]",
        "margin [m]",
        "margin [%]",
        "within seed spread",
    )
    csv_header = (
        "dataset",
        "ground truth",
        "best",
        "best median [m]",
        "best min [m]",
        "best max [m]",
        "best seeds",
        "runner-up",
        "runner-up median [m]",
        "runner-up min [m]",
        "runner-up max [m]",
        "runner-up seeds",
        "margin [m]",
        "margin [%]",
        "within seed spread",
        "dead reckoning median [m]",
    )
    rows: list[list[Cell]] = []
    csv_rows: list[list[object]] = []
    for v in verdicts:
        best, runner = v.best, v.runner_up
        spread = {None: "unknown (1 seed)", True: "yes", False: "no"}[v.within_spread]
        if runner is None:
            spread = "–"
        frac = v.margin_fraction
        rows.append(
            [
                v.dataset,
                best.column if best else "–",
                Num(f"{best.median:.3g}", best.median) if best else Num("–"),
                _range_text(best.low, best.high, best.seeds) if best else "–",
                Num(str(best.seeds), best.seeds) if best else Num("0", 0),
                runner.column if runner else "–",
                Num(f"{runner.median:.3g}", runner.median) if runner else Num("–"),
                _range_text(runner.low, runner.high, runner.seeds) if runner else "–",
                Num(f"{v.margin_m:.3g}", v.margin_m) if v.margin_m is not None else Num("–"),
                Num(f"{100 * frac:.0f}", 100 * frac) if frac is not None else Num("–"),
                spread,
            ]
        )
        csv_rows.append(
            [
                v.dataset,
                v.ground_truth,
                best.column if best else None,
                best.median if best else None,
                best.low if best else None,
                best.high if best else None,
                best.seeds if best else 0,
                runner.column if runner else None,
                runner.median if runner else None,
                runner.low if runner else None,
                runner.high if runner else None,
                runner.seeds if runner else None,
                v.margin_m,
                100 * frac if frac is not None else None,
                None if runner is None else spread,
                v.baseline.median if v.baseline else None,
            ]
        )
    return make_table(
        "verdict",
        "Best estimator per dataset by ATE RMSE (median over seeds; dead reckoning excluded) "
        "and its margin over the runner-up",
        header,
        rows,
        csv_header,
        csv_rows,
    )


def _config(cell: ReportCell) -> RunConfig | None:
    try:
        return read_run_config(cell.run_dir) if cell.run_dir is not None else None
    except OmnislamError:
        return None


def _options_text(options: Mapping[str, str]) -> str:
    return ", ".join(f"{k}={v}" for k, v in sorted(options.items())) or "defaults"


def _images_text(configs: Sequence[RunConfig]) -> str:
    """The camera images of a dataset's runs ("unknown" for runs that predate the count)."""
    counts = sorted({cfg.images for cfg in configs if cfg.images is not None})
    if not counts:
        return provenance.UNKNOWN
    return ", ".join(map(str, counts))


def _path_length(cells: Sequence[ReportCell]) -> str:
    """Path length of the dataset's ground truth, else of dead reckoning."""
    ok = sorted((c for c in cells if c.ok), key=lambda c: (c.seed is None, c.seed or 0))
    if not ok:
        return provenance.UNKNOWN
    try:
        record = read_run_dir(ok[0].run_dir)  # type: ignore[arg-type]
        truth = record.ground_truth.trajectory
        if truth is not None and len(truth) > 1:
            return f"{provenance.path_length_m(truth.positions_w):.1f} m (ground truth)"
        dead = [c for c in ok if c.estimator == BASELINE]
        if dead:
            estimate = read_run_dir(dead[0].run_dir).estimate.trajectory  # type: ignore[arg-type]
            return f"{provenance.path_length_m(estimate.positions_w):.1f} m (dead reckoning)"
    except OmnislamError:
        return provenance.UNKNOWN
    return "unknown (no ground truth, no dead-reckoning run)"


def provenance_rows(
    results_dir: Path, title: str, cells: Sequence[ReportCell], options: ReportOptions
) -> list[tuple[str, str]]:
    """(field, value) of the provenance block; never raises."""
    import omnislam

    rows = [
        ("omnislam version", omnislam.__version__),
        ("git commit", provenance.package_commit()),
        ("date (UTC)", provenance.now_utc()),
        ("command line", provenance.command_line(options.command)),
        ("results", provenance.shown_path(Path(results_dir).resolve())),
    ]
    grid = Path(results_dir) / GRID_COPY
    if grid.is_file():
        digest = provenance.file_digest(grid)
        rows.append(
            (
                "grid",
                f"{provenance.shown_path(grid.resolve())} ({title!r}"
                + (f", sha256 {digest})" if digest else ")"),
            )
        )
    configs = {c.cell_id: _config(c) for c in cells}
    made_with = sorted({cfg.omnislam_version for cfg in configs.values() if cfg is not None})
    if made_with:
        rows.append(("runs made with omnislam", ", ".join(made_with)))
    seeds = sorted({c.seed for c in cells if c.seed is not None})
    rows.append(("seeds", ", ".join(map(str, seeds)) if seeds else "none given"))
    ok, failed = sum(c.ok for c in cells), sum(not c.ok for c in cells)
    rows.append(("runs", f"{ok} successful" + (f", {failed} failed" if failed else "")))
    for dataset in dict.fromkeys(c.dataset for c in cells):
        group = [c for c in cells if c.dataset == dataset]
        group_configs = [configs[c.cell_id] for c in group if configs[c.cell_id] is not None]
        frames = sorted({cfg.frames for cfg in group_configs})  # type: ignore[union-attr]
        source = (
            provenance.shown_path(group_configs[0].dataset)  # type: ignore[union-attr]
            if group_configs
            else provenance.UNKNOWN
        )
        text = f"{source}; frames {', '.join(map(str, frames)) or provenance.UNKNOWN}"
        text += f"; images {_images_text(group_configs)}"
        text += f"; path length {_path_length(group)}"
        loader = {_options_text(cfg.dataset_options) for cfg in group_configs}  # type: ignore[union-attr]
        if loader - {"defaults"}:
            text += f"; loader options {' / '.join(sorted(loader))}"
        rows.append((f"dataset {dataset}", text))
    for column in _columns(cells):
        group = [c for c in cells if c.column == column]
        group_configs = [configs[c.cell_id] for c in group if configs[c.cell_id] is not None]
        estimator = group[0].estimator
        chosen = sorted({_options_text(cfg.estimator_options) for cfg in group_configs})  # type: ignore[union-attr]
        rows.append(
            (f"estimator {column}", f"{estimator}; options: {' / '.join(chosen) or 'unknown'}")
        )
    host = provenance.machine()
    rows.append(
        (
            "machine",
            f"{host.cpu}; {host.cores or provenance.UNKNOWN} cores (os.cpu_count); "
            f"Python {host.python}; {host.platform}",
        )
    )
    return rows


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------


def _first_runs(cells: Sequence[ReportCell]) -> list[tuple[ReportCell, RunRecord]]:
    """The lowest-seed successful run of each column, read from disk."""
    out = []
    for column in _columns(cells):
        group = sorted(
            (c for c in cells if c.column == column and c.ok),
            key=lambda c: (c.seed is None, c.seed or 0),
        )
        if group:
            out.append((group[0], read_run_dir(group[0].run_dir)))  # type: ignore[arg-type]
    return out


def _ate_of(record: RunRecord) -> AteResult | None:
    """The SE(2) ATE the metrics use, with its per-pose errors (None without ground truth)."""
    truth = record.ground_truth.trajectory
    if truth is None:
        return None
    oriented = record.ground_truth.kind is not GroundTruthKind.GPS_PARTIAL
    try:
        return ate(record.estimate.trajectory, truth, Alignment.SE2, truth_has_orientation=oriented)
    except DataError:  # too few poses with ground truth: drawn unaligned
        return None


def _aligned_se2(record: RunRecord, T: np.ndarray) -> np.ndarray:
    xyt = record.estimate.trajectory.se2
    xy = xyt[:, :2] @ T[:2, :2].T + T[:2, 3]
    return np.column_stack([xy, xyt[:, 2] + math.atan2(T[1, 0], T[0, 0])])


def _pose_errors(record: RunRecord, result: AteResult) -> np.ndarray:
    """The position error at every estimate pose [m]: the ATE's errors where a pose has ground
    truth, linearly interpolated over time in between (GPS gaps)."""
    stamps = record.estimate.trajectory.stamps_s
    if len(result.stamps_s) == len(stamps):
        return result.errors_m
    return np.interp(stamps, result.stamps_s, result.errors_m)


#: (file stem, caption) of each figure of a dataset, in report order; each answers one question
FIGURES: tuple[tuple[str, str], ...] = (
    (
        "trajectories",
        "Where along the path does each estimator go wrong? Each estimator's "
        "path (its lowest seed), SE(2)-aligned to the {gt} (dashed) and coloured by its position "
        "error on one logarithmic scale for all panels; the dot marks the start.",
    ),
    (
        "ate-seeds",
        "How accurate is each estimator over seeds? ATE RMSE of every seed (dots) "
        "and its median (bar) against the {gt}.",
    ),
    (
        "accuracy-vs-time",
        "What does accuracy cost? ATE RMSE against the total run time of "
        "every run (log-log; ringed: the median over seeds). Wall-clock times of the machine in "
        "the provenance block.",
    ),
    (
        "error-over-distance",
        "How does the error grow with the distance travelled? RPE RMSE "
        "against segment length of ground-truth travel, translation and rotation (log-log; "
        "lowest seed).",
    ),
    (
        "landmarks",
        "Where does each estimator put the landmarks? Each map (lowest seed) "
        "aligned with its trajectory, over the true landmarks where the data has them; "
        "{sigma:g}-sigma covariance ellipses on maps of at most {most} landmarks (more overlap "
        "into a solid mass).",
    ),
    (
        "step-time",
        "How long does one step take, typically and at worst? Percentiles of the "
        "wall time of each estimator step (lowest seed; the line spans the 5th percentile to the "
        "maximum).",
    ),
    (
        "occupancy",
        "What map do the laser scans make on each trajectory? Occupancy grids "
        "({resolution:g} m cells) built from the scans on the ground truth and on the poses of "
        "every estimator with one pose per scan (any other is named under Notes).",
    ),
)


def _caption(stem: str, gt_label: str, options: ReportOptions) -> str:
    from omnislam.report import plots

    text = dict(FIGURES)[stem]
    return text.format(
        gt=gt_label,
        sigma=plots.ELLIPSE_SIGMA,
        most=plots.ELLIPSE_MAX_LANDMARKS,
        resolution=options.occupancy_resolution_m,
    )


def _dataset_figures(
    dataset: str,
    cells: Sequence[ReportCell],
    colours: Mapping[str, str],
    options: ReportOptions,
    notes: list[str],
) -> list[tuple[str, str, str]]:
    """(file name, caption, SVG) of one dataset's figures (``FIGURES``)."""
    from omnislam.report import plots

    runs = _first_runs(cells)
    if not runs:
        return []
    gt_label = _gt_label(cells)
    stem = "".join(ch if ch.isalnum() or ch in "-_" else "-" for ch in dataset)
    figures: list[tuple[str, str, str]] = []

    order = [kind for kind, _ in FIGURES]

    def add(kind: str, make: Callable[[str], str]) -> None:
        name = f"{stem}-{kind}"
        figures.append((f"{name}.svg", _caption(kind, gt_label, options), make(name)))

    over_seeds = []
    for column in _columns(cells):
        ok = [c for c in cells if c.column == column and c.ok and c.metrics is not None]
        pairs = [
            (c.metrics.ate.rmse_m, c.metrics.timing.total_s)  # type: ignore[union-attr]
            for c in ok
            if c.metrics.ate.rmse_m is not None  # type: ignore[union-attr]
        ]
        if pairs:
            ate_m = np.array([a for a, _ in pairs], dtype=float)
            total = np.array([t if t is not None else np.nan for _, t in pairs], dtype=float)
            over_seeds.append(plots.RunPoints(column, ate_m, total))
    if over_seeds:
        add("ate-seeds", lambda n: plots.ate_over_seeds(n, dataset, over_seeds, colours))
        if any(np.isfinite(p.total_s).any() for p in over_seeds):
            add(
                "accuracy-vs-time",
                lambda n: plots.accuracy_vs_time(n, dataset, over_seeds, colours),
            )

    reference = runs[0][1]
    truth = reference.ground_truth
    truth_xy = truth.trajectory.positions_w[:, :2] if truth.trajectory is not None else None
    truth_lm = truth.landmarks_w[:, :2] if len(truth.landmark_ids) else None
    aligned: dict[str, tuple[np.ndarray, RunRecord]] = {}
    paths = []
    for cell, record in runs:
        result = _ate_of(record)
        T = result.gtTest if result is not None else np.eye(4)
        aligned[cell.column] = (T, record)
        paths.append(
            plots.TrajectorySeries(
                cell.column,
                _aligned_se2(record, T)[:, :2],
                _pose_errors(record, result) if result is not None else None,
                result.rmse_m if result is not None else None,
            )
        )
    add(
        "trajectories",
        lambda n: plots.trajectories(n, dataset, gt_label, truth_xy, paths, colours),
    )

    translation, rotation = [], []
    for cell, _ in runs:
        curve = (cell.metrics.rpe.by_distance if cell.metrics is not None else None) or ()
        if curve:
            lengths = np.array([p.length_m for p in curve], dtype=float)
            trans = np.array([p.trans_rmse_m for p in curve], dtype=float)
            translation.append(plots.Series(cell.column, np.column_stack([lengths, trans])))
            rot = [p.rot_rmse_deg for p in curve]
            if all(r is not None for r in rot):
                rotation.append(
                    plots.Series(cell.column, np.column_stack([lengths, np.array(rot, float)]))
                )
    if translation:
        add(
            "error-over-distance",
            lambda n: plots.error_over_distance(n, dataset, translation, rotation, colours),
        )

    maps = []
    for column, (T, record) in aligned.items():
        estimate = record.estimate
        if not len(estimate.landmark_ids):
            continue
        xy = estimate.landmarks_w[:, :2] @ T[:2, :2].T + T[:2, 3]
        cov = None
        if estimate.landmark_covariances is not None:
            R = T[:2, :2]
            cov = R @ estimate.landmark_covariances[:, :2, :2] @ R.T
        maps.append(plots.LandmarkSeries(column, xy, cov))
    if maps:
        add("landmarks", lambda n: plots.landmark_maps(n, dataset, truth_lm, maps, colours))

    steps = [
        plots.Series(
            cell.column,
            np.column_stack([np.arange(len(record.step_s)), 1e3 * np.asarray(record.step_s)]),
        )
        for cell, record in runs
        if len(record.step_s)
    ]
    if steps:
        add("step-time", lambda n: plots.step_times(n, dataset, steps, colours))
    if options.occupancy:
        grids = _occupancy(reference, aligned, gt_label, options, notes)
        if grids:
            add("occupancy", lambda n: plots.occupancy(n, dataset, grids, colours))
    return sorted(figures, key=lambda f: order.index(f[0][len(stem) + 1 : -len(".svg")]))


def _occupancy(
    reference: RunRecord,
    aligned: Mapping[str, tuple[np.ndarray, RunRecord]],
    gt_label: str,
    options: ReportOptions,
    notes: list[str],
) -> list[tuple[str, object]]:
    """Occupancy grids on the ground truth and on each estimator's poses (laser data only)."""
    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.report.occupancy import occupancy_grid

    config = reference.config
    try:
        resolved = resolve(config.dataset)
        if resolved.format not in LASER_FORMATS:
            return []  # no raw scans in this format: do not load the data for nothing
        sequence = load_dataset(resolved, dict(config.dataset_options))
    except OmnislamError as exc:
        notes.append(f"{config.dataset}: no occupancy grid, the data could not be read ({exc})")
        return []
    laser = sequence.laser
    if laser is None:
        return []
    grids: list[tuple[str, object]] = []

    def build(poses: np.ndarray) -> object:
        return occupancy_grid(
            poses,
            laser.angles_rad,
            laser.ranges_m,
            laser.max_range_m,
            resolution_m=options.occupancy_resolution_m,
        )

    truth = sequence.ground_truth.trajectory
    if truth is not None and len(truth) == len(sequence):
        grids.append((gt_label.split(" (")[0], build(truth.se2)))
    for column, (T, record) in aligned.items():
        if len(record.estimate.trajectory) != len(sequence):
            notes.append(f"{config.dataset}: {column} has no pose per scan; no occupancy grid")
            continue
        grids.append((column, build(_aligned_se2(record, T))))
    return grids


# --------------------------------------------------------------------------------------------
# Exports
# --------------------------------------------------------------------------------------------


def write_landmarks_ply(path: Path, points_w: np.ndarray) -> None:
    """Write a landmark map as a PLY point cloud (open3d; the ``render`` extra).

    Raises:
        MissingExtraError: open3d is not installed (naming the extra).
        DataError: open3d could not write the file.
    """
    from omnislam._optional import require

    o3d = require("open3d")
    cloud = o3d.geometry.PointCloud()
    cloud.points = o3d.utility.Vector3dVector(np.array(points_w, dtype=float).reshape(-1, 3))
    if not o3d.io.write_point_cloud(str(path), cloud, write_ascii=True):
        raise DataError("open3d could not write the point cloud", path)


def _exports(out: Path, cells: Sequence[ReportCell], notes: list[str]) -> None:
    from omnislam.datasets.trajectory_io import write_kitti, write_tum

    for cell in cells:
        if not cell.ok:
            continue
        record = read_run_dir(cell.run_dir)  # type: ignore[arg-type]
        folder = out / "exports" / cell.cell_id
        folder.mkdir(parents=True, exist_ok=True)
        write_tum(folder / "trajectory.tum", record.estimate.trajectory)
        write_kitti(folder / "trajectory.kitti", record.estimate.trajectory)
        if len(record.estimate.landmark_ids):
            try:
                write_landmarks_ply(folder / "landmarks.ply", record.estimate.landmarks_w)
            except MissingExtraError as exc:
                notes.append(f"{cell.cell_id}: landmarks.ply not written: {exc}")
        if GRAPH_G2O in record.attachments:
            (folder / GRAPH_G2O).write_bytes(record.attachments[GRAPH_G2O])


# --------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------

_CSS = """
body{font-family:system-ui,sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}
table{border-collapse:collapse;margin:1em 0;font-size:.9em}
th,td{border:1px solid #ccc;padding:.3em .6em;text-align:right}
th:first-child,td:first-child{text-align:left}
thead{background:#f0f0f0} img{max-width:100%} figure{margin:1.5em 0}
figure svg{display:block;max-width:100%;height:auto}
figcaption{font-size:.9em;color:#444;max-width:60em}
.note{color:#844} .tables{font-size:.8em;margin-top:-.6em} .estimator{white-space:nowrap}
.swatch{display:inline-block;width:.8em;height:.8em;margin-right:.35em;vertical-align:-.05em;
border:1px solid rgba(0,0,0,.25)}
"""


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


def _estimator_availability() -> list[tuple[str, str]]:
    from omnislam.estimators import ESTIMATORS, estimator_factory

    out = []
    for name in ESTIMATORS:
        try:
            estimator_factory(name)
            out.append((name, "available"))
        except (ConfigError, ImportError) as exc:
            reason = "not available yet" if "not available yet" in str(exc) else str(exc)
            out.append((name, reason))
    return out


def write_report(
    results_dir: str | Path, out_dir: str | Path, options: ReportOptions | None = None
) -> ReportSummary:
    """Write ``report.md``, its PNGs, ``index.html`` and the exports into ``out_dir``.

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
        raise output_error(exc, out_dir, "report") from None
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
    datasets = list(dict.fromkeys(c.dataset for c in cells))
    columns = _columns(cells)
    colours = palette.colours(columns)
    md: list[str] = [f"# {title}", ""]
    doc: list[str] = [f"<h1>{html.escape(title)}</h1>"]
    (out / TABLES).mkdir()
    written: set[str] = set()

    def para(text: str) -> None:
        md.extend([text, ""])
        doc.append(f"<p>{html.escape(text)}</p>")

    def table(t: Table) -> None:
        """The table in both outputs, its CSV and LaTeX in tables/ and links to them."""
        name, k = t.name, 2
        while name in written:
            name, k = f"{t.name}-{k}", k + 1
        written.add(name)
        csv_text, tex_text = to_csv(t), to_latex(t)
        (out / TABLES / f"{name}.csv").write_text(csv_text)
        (out / TABLES / f"{name}.tex").write_text(tex_text)
        md.extend(
            [
                _markdown_table(t.header, t.rows),
                "",
                f"*Table as [CSV]({TABLES}/{name}.csv) · [LaTeX]({TABLES}/{name}.tex)*",
                "",
            ]
        )
        links = " · ".join(
            f'<a download="{name}.{ext}" href="data:{mime};charset=utf-8;base64,'
            f'{base64.b64encode(text.encode()).decode("ascii")}">{label}</a>'
            for ext, mime, label, text in (
                ("csv", "text/csv", "CSV", csv_text),
                ("tex", "application/x-tex", "LaTeX", tex_text),
            )
        )
        doc.append(_html_table(t.header, t.rows, colours))
        doc.append(
            f'<p class="tables">Table as {links} (also {TABLES}/{html.escape(name)}.csv and '
            f".tex next to report.md)</p>"
        )

    def heading(text: str, level: int = 2) -> None:
        md.extend(["#" * level + " " + text, ""])
        doc.append(f"<h{level}>{html.escape(text)}</h{level}>")

    made = provenance_rows(results_dir, title, cells, options)
    facts = dict(made)
    commit = facts["git commit"]
    heading("Verdict")
    verdicts = dataset_verdicts(cells)
    table(verdict_table(verdicts))
    for v in verdicts:
        para(v.sentence())
    para(
        "Best: the lowest median ATE RMSE over seeds; dead reckoning is the baseline and is "
        "not ranked. The margin is the runner-up's median minus the best's (in % of the "
        "runner-up's). A margin is within the seed spread when the two estimators' min–max "
        "ranges over seeds overlap; medians less than 1 µm apart are a tie."
    )
    para(
        f"Made with omnislam {facts['omnislam version']} (commit "
        f"{commit[:12] if commit != provenance.UNKNOWN else commit}) on {facts['date (UTC)']}; "
        "see Provenance at the end."
    )
    para(
        "ATE: position RMSE after SE(2) alignment to the ground truth (Sturm et al. 2012); "
        "drift: the same with only the first pose anchored. RPE: segments of the stated length "
        "of ground-truth travel, SE(2) errors for planar runs. Landmark error: after the "
        "trajectory's alignment, matched by id where the data has ids, else by optimal "
        "assignment within a gate. NEES: pose error against the estimator's own covariance "
        "(3 when consistent; '–' when the estimator has no covariance). Values are mean ± "
        "standard deviation over seeds. Every row names the kind of ground truth it is "
        "measured against; pseudo ground truth (CARMEN) comes from another SLAM system and "
        "is not independent."
    )
    heading("ATE RMSE [m] per dataset and estimator")
    headline = []
    for dataset in datasets:
        group = [c for c in cells if c.dataset == dataset]
        row: list[Cell] = [dataset, _gt_label(group)]
        for column in columns:
            ok = [c for c in group if c.column == column and c.ok]
            failed = [c for c in group if c.column == column and not c.ok]
            value = _num(_values(ok, _ate_rmse))
            if failed and not ok:
                value = Num(value.text + " (failed)")
            row.append(value)
        headline.append(row)
    table(
        make_table(
            "ate-rmse",
            "ATE RMSE [m] per dataset and estimator (mean ± std over seeds)",
            ["dataset", "ground truth", *columns],
            headline,
        )
    )
    from omnislam.report import plots

    figure_names: list[str] = []
    say = options.on_step or (lambda stage, done, total: None)
    for index, dataset in enumerate(datasets):
        say(f"figures of {dataset}", index, len(datasets))
        group = [c for c in cells if c.dataset == dataset]
        gt_label = _gt_label(group)
        heading(f"{dataset} — {gt_label}")
        note = next(
            (c.metrics.ground_truth.note for c in group if c.ok and c.metrics is not None), ""
        )
        if note:
            para(f"Ground truth: {note}")
        header, rows = _detail_rows(group)
        # each dataset's own segment (a short run's is shorter: evaluation.segment_for)
        lengths = [c.metrics.rpe.segment_m for c in group if c.ok and c.metrics is not None]
        segment = next((length for length in lengths if length), None)
        if segment:
            header = [h.replace("RPE trans", f"RPE {segment:g} m trans") for h in header]
            header = [h.replace("RPE rot", f"RPE {segment:g} m rot") for h in header]
        table(
            make_table(
                f"{slug(dataset)}-metrics",
                f"{dataset}: metrics per estimator, mean ± std over seeds ({gt_label})",
                header,
                rows,
            )
        )
        association_header, association = association_rows(group)
        if association:
            table(
                make_table(
                    f"{slug(dataset)}-association",
                    f"{dataset}: association decisions per run (estimator_info.json)",
                    association_header,
                    association,
                )
            )
            para(
                "Association decisions as each estimator counts them (estimator_info.json): "
                "landmarks in the final map, landmarks created by the association, sightings "
                "associated with a landmark, left out as ambiguous, rejected by a gate, "
                "tentative landmarks dropped, landmarks merged by a loop closure and loop "
                "closures; '–' where the estimator does not count it."
            )
        for c in group:
            if not c.ok:
                para(f"Failed: {c.cell_id}: {c.error}")
        drawn = _dataset_figures(dataset, group, colours, options, notes) if options.figures else []
        for name, caption, svg in drawn:
            (out / name).write_text(svg)
            figure_names.append(name)
            md.extend([f"![{caption}]({name})", "", f"*{caption}*", ""])
            doc.append(
                f"<figure>{plots.inline_svg(svg, caption)}"
                f"<figcaption>{html.escape(caption)}</figcaption></figure>"
            )
    say("figures", len(datasets), len(datasets))
    if not options.figures:
        para(
            "Figures: not drawn for this report (omnislam report --no-figures); "
            "omnislam report RESULTS_DIR --out DIR draws them from the same results."
        )
    if options.exports:
        say("exports", len(datasets), len(datasets))  # after every dataset's figures
        _exports(out, cells, notes)
        para(
            "Exports: exports/CELL/trajectory.tum and trajectory.kitti for every run, "
            "landmarks.ply where the run has landmarks, graph.g2o where the estimator "
            "exported its factor graph."
        )
    if notes:
        heading("Notes")
        for n in notes:
            md.append(f"- {n}")
            doc.append(f'<p class="note">{html.escape(n)}</p>')
        md.append("")
    heading("Estimators")
    ran = {c.estimator for c in cells}
    table(
        make_table(
            "estimators",
            "Estimators of omnislam and whether they are in this report",
            ["estimator", "status", "in this report"],
            [
                [name, status, "yes" if name in ran else "no"]
                for name, status in _estimator_availability()
            ],
        )
    )
    heading("Provenance")
    table(
        make_table(
            "provenance",
            "How this report was made",
            ["what", "value"],
            [[k, v] for k, v in made],
        )
    )
    para(
        "Options are the estimator options a run was given (estimator_options in each "
        "RUN_DIR's config.yaml); 'defaults' means none were set. Path length is that of the "
        "ground truth, else of dead reckoning."
    )
    (out / REPORT_MD).write_text("\n".join(md))
    page = (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>\n"
        + "\n".join(doc)
        + "\n</body></html>\n"
    )
    (out / REPORT_HTML).write_text(page)
    return figure_names
