"""Run a Grid through any ``concurrent.futures`` executor: a local process pool or Dask.

The runner is written against ``concurrent.futures.Executor`` only: ``ProcessPoolExecutor`` by
default, ``distributed.Client(address).get_executor()`` for a Dask cluster, ``SerialExecutor``
in-process. Workers run ``execute_run(cell.spec)`` and return the RunRecord; this process writes
each cell and evaluates it, so the results folder needs no shared file system and every cell is
written atomically by one writer:

    RESULTS_DIR/
      grid.yaml            the grid as given (marks the folder as a results folder)
      cells/CELL_ID/       one RUN_DIR per cell, with metrics.json (``omnislam evaluate`` output)
      results.json         one row per cell: labels, status, error, metrics (rewritten after
      results.csv          every cell, atomically)

A cell folder appears only complete (written under a hidden name, evaluated, then renamed), so
after an interruption a re-run reuses every finished cell and computes only the others. A cell
whose worker died (process killed, pool broken, Dask ``KilledWorker``) is resubmitted up to
``max_attempts`` times -- on a fresh executor when the old one is broken; a cell that fails with
an omnislam error (bad option, diverged estimator) is deterministic and is not retried.

Numbers do not depend on the executor: the same cell gives the same metrics.json everywhere
except the MEASURED_KEYS of ``compare.run_metrics`` (wall time and memory).
"""

from __future__ import annotations

import csv
import enum
import io
import json
import os
import shutil
import signal
import sys
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import ExitStack
from dataclasses import dataclass, field, replace
from pathlib import Path

from omnislam._files import atomic_write_text, check_output_location, output_error
from omnislam.compare.cache import LOGS
from omnislam.compare.channel import ProgressChannel, StepReporter
from omnislam.compare.evaluation import EvaluationOptions, evaluate_run
from omnislam.compare.execute import RunSpec, cache_track_truth, execute_run, frontend_log_for
from omnislam.compare.grid import Cell, Grid, column_label
from omnislam.compare.perturb import WRONG_ID_OPTION, parse_fraction
from omnislam.compare.run_metrics import (
    CSV_FIELDS,
    RunMetrics,
    read_run_metrics,
    write_run_metrics,
)
from omnislam.compare.rundir import (
    CONFIG,
    METRICS,
    RunRecord,
    read_run_config,
    read_run_dir,
    write_run_dir,
)
from omnislam.errors import ConfigError, DataError, OmnislamError

GRID_COPY = "grid.yaml"
CELLS = "cells"
RESULTS_JSON = "results.json"
RESULTS_CSV = "results.csv"
#: a cell whose worker was lost is submitted at most this many times in all
DEFAULT_MAX_ATTEMPTS = 3
#: seconds the runner waits for a cell before it passes on the workers' progress
PROGRESS_POLL_S = 0.25

#: columns of results.csv before the metrics (``CSV_FIELDS`` of ``compare.run_metrics``)
CSV_LABELS = ("cell", "dataset", "estimator", "override", "seed", "status")


class CellStatus(enum.Enum):
    """What happened to a cell in this invocation."""

    COMPUTED = "computed"
    REUSED = "reused"
    FAILED = "failed"


@dataclass(frozen=True, slots=True)
class CellOutcome:
    """The result of one cell.

    Attributes:
        cell: the cell.
        status: computed now, reused from an earlier invocation, or failed.
        metrics: its metrics (None when failed).
        error: one line saying why it failed (None otherwise).
        attempts: submissions this invocation (0 when reused).
    """

    cell: Cell
    status: CellStatus
    metrics: RunMetrics | None = None
    error: str | None = None
    attempts: int = 0


@dataclass(frozen=True, slots=True)
class CellProgress:
    """What a running cell is doing (``execute.StepCallback``, sent by its worker).

    Attributes:
        cell: the cell.
        stage: "loading", "front end", "running", "final estimate" (in the worker), then
            "storing" (this process writes and evaluates it).
        done: frames stepped so far.
        total: frames of the run (0 while loading).
    """

    cell: Cell
    stage: str
    done: int
    total: int


@dataclass(frozen=True, slots=True)
class GridResult:
    """Every cell's outcome, in grid order."""

    grid: Grid
    out_dir: Path
    outcomes: tuple[CellOutcome, ...] = field(default_factory=tuple)

    def count(self, status: CellStatus) -> int:
        """Number of cells with ``status``."""
        return sum(o.status is status for o in self.outcomes)


#: ``prctl`` option: the signal a process receives when its parent dies (linux/prctl.h)
_PR_SET_PDEATHSIG = 1


class SerialExecutor(Executor):
    """An Executor that runs each call at ``submit`` in this process (debugging, tests)."""

    def submit(self, fn: Callable[..., object], /, *args: object, **kwargs: object) -> Future:
        future: Future = Future()
        try:
            future.set_result(fn(*args, **kwargs))
        except BaseException as exc:  # delivered through the future like a pool would
            future.set_exception(exc)
        return future


def die_with_parent(parent_pid: int) -> None:
    """Worker initializer: end this worker when the process that started it dies.

    On Linux the kernel sends SIGKILL to the worker when its parent dies
    (``prctl(PR_SET_PDEATHSIG)``), so a ``compare`` killed with SIGKILL leaves no worker
    computing cells for nobody; a parent that died before the call is caught by the pid check.
    Elsewhere the pool's own pipes end idle workers.
    """
    if sys.platform.startswith("linux"):
        import ctypes
        import ctypes.util

        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent_pid:
        os._exit(1)


def run_cell(spec: RunSpec, reporter: StepReporter | None = None) -> RunRecord:
    """What a worker runs for one cell: ``execute_run``, its progress sent to ``reporter``."""
    return execute_run(spec, on_step=reporter)


def local_executor_factory(workers: int) -> Callable[[], Executor]:
    """Factory of the default executor: a process pool of ``workers`` ('spawn'), serial if 0.

    The pool's workers die with the process that runs the grid (``die_with_parent``).
    """
    if workers < 0:
        raise ConfigError(f"--workers must be >= 0, got {workers}")

    def make() -> Executor:
        if workers == 0:
            return SerialExecutor()
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        return ProcessPoolExecutor(
            max_workers=workers,
            mp_context=multiprocessing.get_context("spawn"),
            initializer=die_with_parent,
            initargs=(os.getpid(),),
        )

    return make


def check_results_dir(out_dir: Path) -> None:
    """Refuse an existing non-empty folder that is not a results folder of ``omnislam compare``.

    Raises:
        ConfigError: naming the folder.
    """
    out_dir = Path(out_dir)
    if not out_dir.exists():
        check_output_location(out_dir / CELLS, "results folder")
        return
    if not out_dir.is_dir():
        raise ConfigError(f"{out_dir}: exists and is not a folder")
    if any(out_dir.iterdir()) and not (out_dir / GRID_COPY).is_file():
        raise ConfigError(
            f"{out_dir}: exists, is not empty and is not a results folder (no {GRID_COPY}); "
            "refusing to write into it"
        )
    check_output_location(out_dir / CELLS, "results folder")


def _matches(cell_dir: Path, cell: Cell) -> bool:
    """True when ``cell_dir`` holds a finished run of exactly ``cell.spec``."""
    if not (cell_dir / METRICS).is_file() or not (cell_dir / CONFIG).is_file():
        return False
    try:
        config = read_run_config(cell_dir)
    except OmnislamError:
        return False
    spec = cell.spec
    options = {**config.dataset_options, **config.estimator_options}
    wanted = dict(spec.options)
    try:
        wrong_fraction = parse_fraction(wanted.pop(WRONG_ID_OPTION, "0"))
    except ConfigError:
        return False
    if spec.log is not None:
        from omnislam.frontend.observation_log import read_log_key

        if config.frontend_config_hash != read_log_key(Path(spec.log))[1]:
            return False
    elif config.frontend_log is not None:
        return False
    return (
        config.dataset == spec.dataset
        and config.estimator == spec.estimator
        and config.seed == spec.seed
        and options == wanted
        and config.wrong_id_fraction == wrong_fraction
    )


def _evaluation_matches(metrics: RunMetrics, options: EvaluationOptions) -> bool:
    segment, gate = metrics.rpe.segment_m, metrics.landmarks.gate_m
    travel = metrics.rpe.travel_m
    wanted = options.segment_for(travel) if travel is not None else options.rpe_segment_m
    return (segment is None or segment == wanted) and (
        gate is None or gate == options.landmark_gate_m
    )


def store_cell(
    cells_dir: Path, cell: Cell, record: RunRecord, options: EvaluationOptions
) -> RunMetrics:
    """Write one cell atomically: RUN_DIR + metrics.json under a hidden name, then rename.

    The metrics are computed from the files as written (``read_run_dir``), exactly as
    ``omnislam evaluate`` would compute them.
    """
    final = cells_dir / cell.cell_id
    staging = cells_dir / f".{cell.cell_id}.staging-{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    try:
        write_run_dir(staging, record)
        metrics = evaluate_run(read_run_dir(staging), options)
        write_run_metrics(staging / METRICS, metrics)
        if final.exists():
            trash = cells_dir / f".{cell.cell_id}.old-{os.getpid()}"
            os.replace(final, trash)
            os.replace(staging, final)
            shutil.rmtree(trash, ignore_errors=True)
        else:
            os.replace(staging, final)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return metrics


def _row(outcome: CellOutcome) -> dict[str, object]:
    cell = outcome.cell
    return {
        "cell": cell.cell_id,
        "dataset": cell.dataset_label,
        "estimator": cell.estimator_label,
        "column": column_label(cell),
        "override": cell.override_label,
        "seed": cell.spec.seed,
        "status": outcome.status.value,
        "error": outcome.error,
        "metrics": outcome.metrics.to_json() if outcome.metrics is not None else None,
    }


def write_summary(result: GridResult) -> None:
    """Write ``results.json`` and ``results.csv`` atomically (cells finished so far)."""
    rows = [_row(o) for o in result.outcomes]
    summary = {"grid": result.grid.name, "cells": rows}
    atomic_write_text(result.out_dir / RESULTS_JSON, json.dumps(summary, indent=2) + "\n")
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([*CSV_LABELS, *(spec.key for spec in CSV_FIELDS)])
    for outcome, row in zip(result.outcomes, rows, strict=True):
        metrics = outcome.metrics
        values = [None if metrics is None else spec.json_value(metrics) for spec in CSV_FIELDS]
        writer.writerow([row[k] for k in CSV_LABELS] + ["" if v is None else v for v in values])
    atomic_write_text(result.out_dir / RESULTS_CSV, buffer.getvalue())


def prepare_frontend_logs(grid: Grid, out_dir: Path) -> Grid:
    """Run the shared front end once per dataset with images or laser scans; every cell
    replays its log.

    For each dataset of the grid whose sequence has images (synthetic omni runs, image folders)
    or laser scans (CARMEN) and whose cells name no log of their own,
    ``execute.frontend_log_for`` writes (or reuses, when dataset and configuration are
    unchanged) ``out_dir/logs/<dataset>.npz`` in this process, and every cell of that dataset
    gets it as ``RunSpec.log``: all estimators replay the same observations, so a comparison
    measures estimators, not front ends (``omnislam run`` without ``--log`` replays the same log
    from the cache). Other datasets keep their own sightings.

    Returns:
        The grid with the log paths filled in.
    """
    from omnislam.core.modality import Modality
    from omnislam.datasets.registry import load_dataset
    from omnislam.estimators import ESTIMATORS

    logs: dict[str, str | None] = {}
    for cell in grid.cells:
        dataset = cell.spec.dataset
        if cell.spec.log is not None or dataset in logs:
            continue
        sequence = load_dataset(dataset)
        path = frontend_log_for(sequence, dataset, out_dir / LOGS, progress=True)
        logs[dataset] = None if path is None else str(path)
        bearings = any(
            Modality.BEARINGS_3D in ESTIMATORS[c.spec.estimator].modalities
            for c in grid.cells
            if c.spec.dataset == dataset
        )
        if path is not None and bearings:  # once here, not once per worker
            cache_track_truth(sequence, path, progress=True)
    cells = tuple(
        cell
        if cell.spec.log is not None or logs.get(cell.spec.dataset) is None
        else replace(cell, spec=replace(cell.spec, log=logs[cell.spec.dataset]))
        for cell in grid.cells
    )
    return replace(grid, cells=cells)


def run_grid(
    grid: Grid,
    out_dir: str | Path,
    executor_factory: Callable[[], Executor] | None = None,
    *,
    max_attempts: int = DEFAULT_MAX_ATTEMPTS,
    on_outcome: Callable[[CellOutcome], None] | None = None,
    on_progress: Callable[[CellProgress], None] | None = None,
    reuse: bool = True,
) -> GridResult:
    """Run every cell of ``grid`` not already finished in ``out_dir``.

    Args:
        grid: a validated grid.
        out_dir: RESULTS_DIR (created; an existing results folder is resumed).
        executor_factory: makes the executor (called again when one breaks); default a
            process pool of ``os.cpu_count()`` workers.
        max_attempts: submissions per cell when its worker is lost.
        on_outcome: called with every cell's outcome as it is known (progress bars).
        on_progress: called in this process with what running cells are doing, frames
            stepped included, as their workers report it (``channel``; workers on another
            machine report nothing until their cell is done).
        reuse: keep the cells ``out_dir`` already holds for this grid (resume); False computes
            every cell again (each replaces its old folder atomically when done) and removes
            the cell folders of cells the grid no longer has.

    Returns:
        GridResult with every cell's outcome.

    Raises:
        ConfigError: ``out_dir`` is a non-empty folder that is not a results folder.
    """
    out_dir = Path(out_dir)
    check_results_dir(out_dir)
    if executor_factory is None:
        executor_factory = local_executor_factory(os.cpu_count() or 1)
    cells_dir = out_dir / CELLS
    try:
        cells_dir.mkdir(parents=True, exist_ok=True)
        for stale in cells_dir.glob(".*"):  # staging folders of an interrupted invocation
            shutil.rmtree(stale, ignore_errors=True)
        atomic_write_text(out_dir / GRID_COPY, grid.text)
    except OSError as exc:
        raise output_error(exc, out_dir, "results folder") from None
    grid = prepare_frontend_logs(grid, out_dir)

    outcomes: dict[str, CellOutcome] = {}
    pending: list[Cell] = []
    for cell in grid.cells:
        cell_dir = cells_dir / cell.cell_id
        if reuse and _matches(cell_dir, cell):
            try:
                metrics: RunMetrics | None = read_run_metrics(cell_dir / METRICS)
            except DataError:  # unreadable or of another layout: evaluate the run again
                metrics = None
            if metrics is None or not _evaluation_matches(metrics, grid.evaluation):
                metrics = evaluate_run(read_run_dir(cell_dir), grid.evaluation)
                write_run_metrics(cell_dir / METRICS, metrics)
            outcomes[cell.cell_id] = CellOutcome(cell, CellStatus.REUSED, metrics)
            if on_outcome is not None:
                on_outcome(outcomes[cell.cell_id])
        else:
            pending.append(cell)

    def summary() -> GridResult:
        ordered = tuple(outcomes[c.cell_id] for c in grid.cells if c.cell_id in outcomes)
        return GridResult(grid, out_dir, ordered)

    def finish(outcome: CellOutcome) -> None:
        outcomes[outcome.cell.cell_id] = outcome
        write_summary(summary())
        if on_outcome is not None:
            on_outcome(outcome)

    if pending:
        _execute(pending, grid, cells_dir, executor_factory, max_attempts, finish, on_progress)
    if not reuse:
        wanted = {cell.cell_id for cell in grid.cells}
        for old in cells_dir.iterdir():
            if old.is_dir() and not old.name.startswith(".") and old.name not in wanted:
                shutil.rmtree(old, ignore_errors=True)
    result = summary()
    write_summary(result)
    return result


def _execute(
    pending: list[Cell],
    grid: Grid,
    cells_dir: Path,
    executor_factory: Callable[[], Executor],
    max_attempts: int,
    finish: Callable[[CellOutcome], None],
    on_progress: Callable[[CellProgress], None] | None = None,
) -> None:
    """Submit the pending cells, store results as they arrive, resubmit lost ones."""
    attempts = {cell.cell_id: 0 for cell in pending}
    by_id = {cell.cell_id: cell for cell in pending}
    stack = ExitStack()
    channel = stack.enter_context(ProgressChannel()) if on_progress is not None else None
    try:
        executor = executor_factory()
    except BaseException:
        stack.close()
        raise
    running: dict[Future, Cell] = {}

    def submit(cell: Cell) -> None:
        nonlocal executor
        attempts[cell.cell_id] += 1
        reporter = channel.reporter(cell.cell_id) if channel is not None else None
        try:
            future = executor.submit(run_cell, cell.spec, reporter)
        except (BrokenProcessPool, RuntimeError):  # a broken or shut down pool: renew it
            executor.shutdown(wait=False, cancel_futures=True)
            executor = executor_factory()
            future = executor.submit(run_cell, cell.spec, reporter)
        running[future] = cell

    def relay() -> None:
        if channel is None or on_progress is None:
            return
        for message in channel.drain():
            cell = by_id.get(message.key)
            if cell is not None:
                on_progress(CellProgress(cell, message.stage, message.done, message.total))

    try:
        for cell in pending:
            submit(cell)
        while running:
            done, _ = wait(
                list(running),
                timeout=PROGRESS_POLL_S if channel is not None else None,
                return_when=FIRST_COMPLETED,
            )
            relay()
            for future in done:
                cell = running.pop(future)
                try:
                    record = future.result()
                except OmnislamError as exc:  # deterministic: bad option, estimator failure
                    finish(CellOutcome(cell, CellStatus.FAILED, error=str(exc), attempts=1))
                    continue
                except BaseException as exc:  # worker lost (killed, pool broken, cancelled)
                    if isinstance(exc, KeyboardInterrupt):
                        raise
                    if attempts[cell.cell_id] < max_attempts:
                        submit(cell)
                    else:
                        error = f"{type(exc).__name__}: {exc}".strip()
                        finish(
                            CellOutcome(
                                cell,
                                CellStatus.FAILED,
                                error=f"gave up after {attempts[cell.cell_id]} attempts ({error})",
                                attempts=attempts[cell.cell_id],
                            )
                        )
                    continue
                if on_progress is not None:
                    frames = record.config.frames
                    on_progress(CellProgress(cell, "storing", frames, frames))
                metrics = store_cell(cells_dir, cell, record, grid.evaluation)
                finish(
                    CellOutcome(cell, CellStatus.COMPUTED, metrics, attempts=attempts[cell.cell_id])
                )
    except BaseException:  # interrupted: keep finished cells, do not wait for running ones
        for future in running:
            future.cancel()
        executor.shutdown(wait=False, cancel_futures=True)
        stack.close()
        raise
    executor.shutdown(wait=True)
    stack.close()
