"""What a report is made of: the runs of a results folder, a RUN_DIR or a folder of RUN_DIRs.

``collect_cells`` reads them as ReportCells (``results.json`` of ``omnislam compare`` checked
row by row against the types the runner writes; a RUN_DIR without ``metrics.json`` evaluated in
memory). The helpers below group them the way every part of the report does: estimator columns
with the dead-reckoning baseline first, a metric's values over seeds, the label of a dataset's
ground truth.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from omnislam.errors import DataError
from omnislam.harness.evaluation import GROUND_TRUTH_LABELS, evaluate_run
from omnislam.harness.layout import CELLS, CONFIG, METRICS, RESULTS_JSON
from omnislam.harness.rundir import RunConfig, read_run_config, read_run_dir
from omnislam.metrics.run_metrics import RunMetrics, read_run_metrics

#: estimator name of the baseline column
BASELINE = "deadreckoning"

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
        config: its ``config.yaml`` (None when failed): what the run consumed.
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
    config: RunConfig | None = None

    @property
    def ok(self) -> bool:
        return self.metrics is not None and self.run_dir is not None


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
        config=config,
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
                        config=read_run_config(run_dir) if ok else None,
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


#: one number of a run's metrics (None when it has none)
Metric = Callable[[RunMetrics], float | int | None]


def values(cells: Sequence[ReportCell], metric: Metric) -> list[float]:
    """``metric`` of every cell that has metrics and a value for it."""
    found = (metric(c.metrics) for c in cells if c.metrics is not None)
    return [float(v) for v in found if v is not None]


def columns(cells: Sequence[ReportCell]) -> list[str]:
    """Column labels with the baseline first, then in grid order."""
    labels = list(dict.fromkeys(c.column for c in cells))
    return sorted(labels, key=lambda col: col != BASELINE)


def gt_label(cells: Sequence[ReportCell]) -> str:
    """How the report names the ground truth of these cells (of the first with metrics)."""
    for c in cells:
        if c.metrics is not None:
            return GROUND_TRUTH_LABELS[c.metrics.ground_truth.kind]
    return "unknown ground truth"


def ate_rmse(m: RunMetrics) -> float | None:
    """The metric the report ranks by: SE(2)-aligned ATE RMSE [m]."""
    return m.ate.rmse_m


def input_label(cell: ReportCell) -> str:
    """What a run consumed: its modality and where the sightings came from (the front end's
    log or the dataset's own), and whether it localised in a prior map; "odometry" for one
    that uses no sightings (dead reckoning). Only runs with one label are ranked together."""
    config = cell.config
    if config is None or config.modality is None:
        return "odometry"
    text = config.modality
    if config.frontend_log:
        text += " (front end)"
    if config.prior_map:
        text += " in a prior map"
    return text


def registered_name(cell: ReportCell) -> str:
    """The registry name of a run's estimator: its RUN_DIR's ``config.estimator`` (a grid's label
    such as ``ekfslam-poles`` names a column, not an estimator), else the results row's name."""
    return cell.config.estimator if cell.config is not None else cell.estimator


def family_of(cell: ReportCell) -> str:
    """The method family of a run's estimator (``estimators.Family`` value); EXTERNAL for
    results read from another system's files, which no registry entry describes."""
    from omnislam.estimators import ESTIMATORS, Family

    entry = ESTIMATORS.get(registered_name(cell))
    return (entry.family if entry is not None else Family.EXTERNAL).value


def method_of(cell: ReportCell) -> str:
    """The method a run's estimator is a variant of: registry names that share a factory
    module, configuration and preset (``graphslam`` and ``graphslam-batch``) are one method."""
    from omnislam.estimators import ESTIMATORS

    entry = ESTIMATORS.get(registered_name(cell))
    if entry is None:
        return cell.estimator
    return "|".join((entry.target.split(":")[0], entry.config, entry.preset, entry.check))


def deterministic(cells: Sequence[ReportCell]) -> bool:
    """The successful runs of one column are a deterministic estimator on one input: its
    registry entry draws no random numbers, the harness perturbed nothing and every run read
    the same data, so every seed gives the same run."""
    from omnislam.estimators import ESTIMATORS

    ok = [c for c in cells if c.ok and c.config is not None]
    if not ok:
        return False
    entry = ESTIMATORS.get(registered_name(ok[0]))
    if entry is None or entry.stochastic:
        return False
    configs = [c.config for c in ok if c.config is not None]
    return len({c.dataset_path for c in configs}) == 1 and not any(
        c.wrong_id_fraction or c.clutter_per_frame for c in configs
    )
