"""Run a Grid through any ``concurrent.futures`` executor: a local process pool or Dask.

The runner is written against ``concurrent.futures.Executor`` only: ``ProcessPoolExecutor`` by
default, a Dask client's executor for a cluster (``dask_executor_factory``), ``SerialExecutor``
in-process. Two kinds of task run on the workers:

1. ``prepare_dataset``, once per dataset: render a synthetic preset that is not in the cache
   (``harness.renders``) and run the shared front end unless its log is current;
2. ``run_cell``, once per cell as soon as its dataset is ready (a cell that reads another
   cell's map, ``Cell.prior_from``, once that cell is stored): ``execute_run(cell.spec)``,
   returning the RunRecord and what it cost; for another system's results
   (``Cell.external``) ``read_external_cell`` instead, which reads them from their files (and is
   never reused: reading them again is cheap and sees a changed file).

Both return the warnings they logged instead of printing them where they ran
(``harness.held_warnings``); the GridResult holds each distinct one once, for the command to
print after its progress.

This process writes each cell and evaluates it, so every cell is written atomically by one
writer; the workers read the data, the cache (renders) and the front-end logs in
RESULTS_DIR/logs, so on a cluster those must be on a shared file system at the same paths:

    RESULTS_DIR/
      grid.yaml            the grid as given (marks the folder as a results folder)
      logs/                the shared front end's log of each dataset with images or scans
      cells/CELL_ID/       one RUN_DIR per cell, with metrics.json (``omnislam evaluate`` output)
                           and cell_time.json (wall and CPU time on its worker)
      results.json         one row per cell: labels, status, error, metrics, cell time
      results.csv          (rewritten after every cell, atomically)

A cell folder appears only complete (written under a hidden name, evaluated, then renamed), so
after an interruption a re-run reuses every finished cell and computes only the others. A task
whose worker died (process killed, pool broken, Dask ``KilledWorker``) is resubmitted up to
``max_attempts`` times -- on a fresh executor when the old one is broken; a task that fails with
an omnislam error (bad option, diverged estimator) is deterministic and is not retried.

Numbers do not depend on the executor: the same cell gives the same metrics.json everywhere
except the MEASURED_KEYS of ``metrics.run_metrics`` (wall time and memory).
"""

from __future__ import annotations

import csv
import enum
import functools
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

from omnislam._files import (
    atomic_write_text,
    atomic_write_texts,
    check_output_location,
    output_error,
)
from omnislam._progress import say
from omnislam.errors import ConfigError, DataError, OmnislamError
from omnislam.frontend.timing import cpu_with_children_s
from omnislam.harness.channel import ProgressChannel, StepReporter
from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
from omnislam.harness.execute import RunSpec, StepCallback, execute_run, parse_run_options
from omnislam.harness.external import ExternalResult
from omnislam.harness.grid import Cell, Grid, column_label
from omnislam.harness.held_warnings import LoggedWarning, distinct, held_warnings
from omnislam.harness.layout import (
    CELL_TIME,
    CELLS,
    CONFIG,
    GRID_COPY,
    LOGS,
    METRICS,
    RESULTS_CSV,
    RESULTS_JSON,
)
from omnislam.harness.prior import PRIOR_MAP_OPTION
from omnislam.harness.renders import RenderSpec
from omnislam.harness.rundir import RunRecord, read_run_config, read_run_dir, write_run_dir
from omnislam.metrics.run_metrics import (
    CSV_FIELDS,
    RunMetrics,
    read_run_metrics,
    write_run_metrics,
)

#: a cell whose worker was lost is submitted at most this many times in all
DEFAULT_MAX_ATTEMPTS = 3
#: seconds the runner waits for a task before it passes on the workers' progress
PROGRESS_POLL_S = 0.25
#: channel keys of dataset preparations start with this (cell ids never do)
PREPARE_KEY = "prepare:"

#: columns of results.csv before the metrics (``CSV_FIELDS`` of ``metrics.run_metrics``)
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
        time: what the cell cost on its worker (``CellTime``; for a reused cell, when it was
            computed), None when failed or not recorded.
    """

    cell: Cell
    status: CellStatus
    metrics: RunMetrics | None = None
    error: str | None = None
    attempts: int = 0
    time: CellTime | None = None


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
class PrepareProgress:
    """What the preparation of a dataset is doing (``prepare_dataset``, sent by its worker).

    Attributes:
        dataset: the dataset (``RunSpec.dataset``).
        label: how to name it: the preset and seed of a render, else the dataset's label.
        stage: "simulating", "rendering", "front end", "track truth"; "done" when it finished
            (or failed).
        done: images done in the stage.
        total: images of the stage (0 where nothing is counted).
    """

    dataset: str
    label: str
    stage: str
    done: int
    total: int


@dataclass(frozen=True, slots=True)
class GridResult:
    """Every cell's outcome, in grid order, and each distinct warning the tasks logged once
    (``harness.held_warnings``; a loader's warning is logged by every cell of its dataset)."""

    grid: Grid
    out_dir: Path
    outcomes: tuple[CellOutcome, ...] = field(default_factory=tuple)
    warnings: tuple[LoggedWarning, ...] = ()

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


def dask_executor_factory(client: object) -> Callable[[], Executor]:
    """Factory of the executor of a Dask ``distributed.Client``: its tasks are impure.

    Dask names a pure task (``Client.submit``'s default) after its function and arguments, so a
    task resubmitted after its worker died would get the name of the failed one and the
    scheduler would answer with that one's ``KilledWorker`` at once: every attempt would fail
    without running. ``pure=False`` gives each submission a name of its own.

    Args:
        client: a connected ``distributed.Client``.
    """
    return functools.partial(client.get_executor, pure=False)  # type: ignore[attr-defined]


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
    try:  # every option but the harness's is the loader's or the estimator's: no split needed
        wanted = parse_run_options(spec.options, loader_keys=())
    except ConfigError:
        return False
    if config.prior_map != wanted.prior_map:
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
        and options == wanted.estimator
        and config.wrong_id_fraction == wanted.wrong_id_fraction
        and config.clutter_per_frame == wanted.clutter_per_frame
    )


def _evaluation_matches(metrics: RunMetrics, options: EvaluationOptions) -> bool:
    segment, gate = metrics.rpe.segment_m, metrics.landmarks.gate_m
    travel = metrics.rpe.travel_m
    wanted = options.segment_for(travel) if travel is not None else options.rpe_segment_m
    return (segment is None or segment == wanted) and (
        gate is None or gate == options.landmark_gate_m
    )


def store_cell(
    cells_dir: Path,
    cell: Cell,
    record: RunRecord,
    options: EvaluationOptions,
    time_taken: CellTime | None = None,
) -> RunMetrics:
    """Write one cell atomically: RUN_DIR + metrics.json (+ ``cell_time.json``) under a hidden
    name, then rename.

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
        if time_taken is not None:
            (staging / CELL_TIME).write_text(json.dumps(time_taken.to_json()) + "\n")
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
        "cell_time": outcome.time.to_json() if outcome.time is not None else None,
    }


def write_summary(result: GridResult) -> None:
    """Write ``results.json`` and ``results.csv`` atomically (cells finished so far).

    Raises:
        ConfigError: a file that cannot be written (a full disk): the previous summary stays.
    """
    try:
        _write_summary(result)
    except OSError as exc:
        raise output_error(exc, result.out_dir, "results summary", atomic=True) from None


def _write_summary(result: GridResult) -> None:
    """``write_summary`` without the translation of its errors (both files or neither)."""
    rows = [_row(o) for o in result.outcomes]
    summary = {"grid": result.grid.name, "cells": rows}
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow([*CSV_LABELS, *(spec.key for spec in CSV_FIELDS)])
    for outcome, row in zip(result.outcomes, rows, strict=True):
        metrics = outcome.metrics
        values = [None if metrics is None else spec.json_value(metrics) for spec in CSV_FIELDS]
        writer.writerow([row[k] for k in CSV_LABELS] + ["" if v is None else v for v in values])
    atomic_write_texts({
        result.out_dir / RESULTS_JSON: json.dumps(summary, indent=2) + "\n",
        result.out_dir / RESULTS_CSV: buffer.getvalue(),
    })


@dataclass(frozen=True, slots=True)
class Prepared:
    """What the preparation of one dataset did (``prepare_dataset``).

    Attributes:
        dataset: the dataset argument.
        log: the shared front end's log every cell of the dataset replays (None: the
            dataset's own sightings).
        rendered: the synthetic render was made now (False: it was in the cache).
        frontend_computed: the front end ran now (False: its log was cached).
        truth_computed: the true points of the log's tracks were computed now (False: cached,
            or not needed).
        wall_s, cpu_s: wall-clock and CPU time of the preparation [s] (the CPU of this process
            and of its ended children: the front end's workers when it pipelines).
        warnings: what it logged at WARNING or above, each once.
    """

    dataset: str
    log: str | None
    rendered: bool = False
    frontend_computed: bool = False
    truth_computed: bool = False
    wall_s: float = 0.0
    cpu_s: float = 0.0
    warnings: tuple[LoggedWarning, ...] = ()


def prepare_dataset(
    dataset: str,
    render: RenderSpec | None,
    logs_dir: str,
    track_truth: bool = False,
    on_step: StepCallback | None = None,
) -> Prepared:
    """Make what every cell of a dataset needs, once; runs on a worker.

    Renders a synthetic dataset that is not in the cache yet (``harness.renders``), then runs
    the shared front end on a dataset with images or laser scans unless its log in
    ``logs_dir`` is current (``execute.frontend_log_for``), so all estimators replay the same
    observations and a comparison measures estimators, not front ends (``omnislam run``
    without ``--log`` replays the same log from the cache). Other datasets keep their own
    sightings. A dataset scored against a reference solution (``harness.reference``) gets it
    computed into the cache here, once, not by each of its cells; so do the true points of the
    log's tracks (``track_truth.cache_track_truth``) when ``track_truth`` (some cell of the dataset
    consumes bearings-3d), so the workers running its cells read them from the cache.
    ``on_step(stage, done, total)`` hears what takes time: "simulating", "rendering" (images),
    "front end" (images), "track truth" (images). What it logs at WARNING or above is held
    back and returned (``Prepared.warnings``).
    """
    with held_warnings() as held:
        prepared = _prepare_dataset(dataset, render, logs_dir, track_truth, on_step)
    return replace(prepared, warnings=distinct(held))


def _prepare_dataset(
    dataset: str,
    render: RenderSpec | None,
    logs_dir: str,
    track_truth: bool = False,
    on_step: StepCallback | None = None,
) -> Prepared:
    """``prepare_dataset`` without holding its warnings back."""
    import time

    from omnislam.datasets.registry import load_dataset, resolve
    from omnislam.harness.execute import frontend_log_for, log_file_name
    from omnislam.harness.reference import reference_for
    from omnislam.harness.renders import ensure_render
    from omnislam.harness.track_truth import cache_track_truth, truth_cache_path

    log_path = Path(logs_dir) / log_file_name(dataset)

    def stamp(path: Path) -> int | None:
        try:
            return path.stat().st_mtime_ns
        except OSError:
            return None

    truth_path = truth_cache_path(log_path)
    # the front end's worker processes (pipelined where this process may have children) count
    wall, cpu = time.perf_counter(), cpu_with_children_s()

    def counting(stage: str) -> Callable[[int, int], None] | None:
        if on_step is None:
            return None
        return lambda done, total: on_step(stage, done, total)

    rendered = ensure_render(render, dataset, on_step) if render is not None else False
    resolved = resolve(dataset)
    sequence = load_dataset(resolved)
    reference_for(resolved.format, resolved.path, sequence)
    before, truth_before = stamp(log_path), stamp(truth_path)
    log = frontend_log_for(sequence, dataset, Path(logs_dir), on_image=counting("front end"))
    truth_computed = False
    if log is not None and track_truth:
        cache_track_truth(sequence, log, on_image=counting("track truth"))
        truth_computed = stamp(truth_path) != truth_before  # unchanged: cached or no truth
    computed = log is not None and stamp(log_path) != before
    return Prepared(
        dataset,
        None if log is None else str(log),
        rendered,
        computed,
        truth_computed,
        time.perf_counter() - wall,
        cpu_with_children_s() - cpu,
    )


@dataclass(frozen=True, slots=True)
class CellTime:
    """What one cell cost on its worker, loading and replay included (``cell_time.json``).

    Attributes:
        wall_s: wall-clock time of ``execute_run`` [s].
        cpu_s: CPU time of the worker process during it [s] (the honest measure on a loaded
            machine).
        host: the worker's host name.
    """

    wall_s: float
    cpu_s: float
    host: str = ""

    def to_json(self) -> dict[str, object]:
        return {"wall_s": self.wall_s, "cpu_s": self.cpu_s, "host": self.host}


def run_cell(
    spec: RunSpec, reporter: StepReporter | None = None
) -> tuple[RunRecord, CellTime, tuple[LoggedWarning, ...]]:
    """``execute_run(spec)``, what it cost and the warnings it logged (held back, each once);
    runs on a worker, its progress sent to ``reporter`` (``harness.channel``)."""
    import socket
    import time

    wall, cpu = time.perf_counter(), time.process_time()
    with held_warnings() as held:
        record = execute_run(spec, on_step=reporter)
    cost = CellTime(time.perf_counter() - wall, time.process_time() - cpu, socket.gethostname())
    return record, cost, distinct(held)


def read_external_cell(
    spec: RunSpec, external: ExternalResult, reporter: StepReporter | None = None
) -> tuple[RunRecord, CellTime, tuple[LoggedWarning, ...]]:
    """``harness.external.external_record``: another system's results as a cell, what reading
    them cost and the warnings it logged, as ``run_cell``; runs on a worker (``reporter``
    hears that it is loading)."""
    import socket
    import time

    from omnislam.harness.external import external_record

    if reporter is not None:
        reporter("loading", 0, 0)
    wall, cpu = time.perf_counter(), time.process_time()
    with held_warnings() as held:
        record = external_record(spec, external)
    cost = CellTime(time.perf_counter() - wall, time.process_time() - cpu, socket.gethostname())
    return record, cost, distinct(held)


def read_cell_time(cell_dir: Path) -> CellTime | None:
    """The ``cell_time.json`` of a cell folder (None when absent or unreadable)."""
    try:
        raw = json.loads((cell_dir / CELL_TIME).read_text())
        return CellTime(float(raw["wall_s"]), float(raw["cpu_s"]), str(raw.get("host", "")))
    except (OSError, ValueError, KeyError, TypeError):
        return None


def _with_prior_maps(grid: Grid, cells_dir: Path) -> Grid:
    """Fill ``prior_map`` of every cell that reads another cell's map with that cell's folder."""
    cells = tuple(
        cell
        if cell.prior_from is None
        else replace(
            cell,
            spec=replace(
                cell.spec,
                options={**cell.spec.options, PRIOR_MAP_OPTION: str(cells_dir / cell.prior_from)},
            ),
        )
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
    on_progress: Callable[[CellProgress | PrepareProgress], None] | None = None,
    reuse: bool = True,
) -> GridResult:
    """Run every cell of ``grid`` not already finished in ``out_dir``.

    First every dataset is prepared on the executor (``prepare_dataset``: renders, front-end
    logs in ``out_dir/logs``, the true points of the logs' tracks where a cell consumes
    bearings-3d); as each is ready its finished cells are reused and the others submitted -- a
    cell reading another cell's map (``Cell.prior_from``) once that cell is stored, and
    computed again whenever it is.

    Args:
        grid: a validated grid.
        out_dir: RESULTS_DIR (created; an existing results folder is resumed). Workers read
            the logs and prior maps in it, so on a cluster it must be shared.
        executor_factory: makes the executor (called again when one breaks); default a
            process pool of ``os.cpu_count()`` workers.
        max_attempts: submissions per task when its worker is lost.
        on_outcome: called with every cell's outcome as it is known (progress bars).
        on_progress: called in this process with what running cells are doing, frames
            stepped included (``CellProgress``), and with what a dataset's preparation is doing,
            images rendered or through the front end (``PrepareProgress``; "done" when it
            ends), as their workers report it (``channel``; workers on another machine report
            nothing until their task is done).
        reuse: keep the cells ``out_dir`` already holds for this grid (resume); False computes
            every cell again (each replaces its old folder atomically when done) and removes
            the cell folders of cells the grid no longer has.

    Returns:
        GridResult with every cell's outcome.

    Raises:
        ConfigError: ``out_dir`` is a non-empty folder that is not a results folder.
    """
    out_dir = Path(out_dir).absolute()
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
    grid = _with_prior_maps(grid, cells_dir)

    outcomes: dict[str, CellOutcome] = {}
    tasks: list[_GridRun] = []

    def summary() -> GridResult:
        ordered = tuple(outcomes[c.cell_id] for c in grid.cells if c.cell_id in outcomes)
        return GridResult(grid, out_dir, ordered, distinct(w for t in tasks for w in t.warnings))

    def finish(outcome: CellOutcome) -> None:
        outcomes[outcome.cell.cell_id] = outcome
        if outcome.status is not CellStatus.REUSED:
            write_summary(summary())
        if on_outcome is not None:
            on_outcome(outcome)

    tasks.append(
        _GridRun(grid, out_dir, executor_factory, max_attempts, finish, on_progress, reuse=reuse)
    )
    tasks[0].run()
    if not reuse:
        wanted = {cell.cell_id for cell in grid.cells}
        for old in cells_dir.iterdir():
            if old.is_dir() and not old.name.startswith(".") and old.name not in wanted:
                shutil.rmtree(old, ignore_errors=True)
    result = summary()
    write_summary(result)
    return result


def _reuse(cell: Cell, cell_dir: Path, options: EvaluationOptions) -> CellOutcome | None:
    """The outcome of a finished cell that can be reused as it is (None: compute it)."""
    if not _matches(cell_dir, cell):
        return None
    try:
        metrics: RunMetrics | None = read_run_metrics(cell_dir / METRICS)
    except DataError:  # unreadable or of another layout: evaluate the run again
        metrics = None
    if metrics is None or not _evaluation_matches(metrics, options):
        metrics = evaluate_run(read_run_dir(cell_dir), options)
        write_run_metrics(cell_dir / METRICS, metrics)
    return CellOutcome(cell, CellStatus.REUSED, metrics, time=read_cell_time(cell_dir))


class _GridRun:
    """The tasks of one invocation: prepare every dataset, then its cells, in dependency order.

    A task whose worker was lost is resubmitted up to ``max_attempts`` times (on a fresh
    executor when the old one is broken); one that fails with an omnislam error is
    deterministic and fails at once, with every cell that depends on it. With ``on_progress``
    every cell gets a ``StepReporter`` of a ``ProgressChannel`` and the wait for tasks polls
    every PROGRESS_POLL_S to relay what the workers report; without ``reuse`` no finished cell
    is reused.
    """

    def __init__(
        self,
        grid: Grid,
        out_dir: Path,
        executor_factory: Callable[[], Executor],
        max_attempts: int,
        finish: Callable[[CellOutcome], None],
        on_progress: Callable[[CellProgress | PrepareProgress], None] | None = None,
        *,
        reuse: bool = True,
    ) -> None:
        self.grid = grid
        self.cells_dir = out_dir / CELLS
        self.logs_dir = out_dir / LOGS
        self.factory = executor_factory
        self.max_attempts = max_attempts
        self.finish = finish
        self.executor: Executor | None = None
        self.running: dict[Future, tuple[str, str]] = {}  # future -> (kind, key)
        self.attempts: dict[tuple[str, str], int] = {}
        self.by_id = {c.cell_id: c for c in grid.cells}
        self.status: dict[str, CellStatus] = {}
        self.waiting: dict[str, list[Cell]] = {}  # cell id -> cells reading its map
        self.logs: dict[str, str | None] = {}
        self.on_progress = on_progress
        self.reuse = reuse
        self.channel: ProgressChannel | None = None
        self.announced: set[str] = set()  # datasets whose preparation progress was passed on
        self.warnings: list[LoggedWarning] = []  # what the tasks logged, in arrival order

    # -- submission ----------------------------------------------------------------------
    def _submit(self, kind: str, key: str, fn: Callable[..., object], *args: object) -> None:
        self.attempts[(kind, key)] = self.attempts.get((kind, key), 0) + 1
        if self.executor is None:
            self.executor = self.factory()
        try:
            future = self.executor.submit(fn, *args)
        except (BrokenProcessPool, RuntimeError):  # a broken or shut down pool: renew it
            self.executor.shutdown(wait=False, cancel_futures=True)
            self.executor = self.factory()
            future = self.executor.submit(fn, *args)
        self.running[future] = (kind, key)

    def _submit_prepare(self, dataset: str) -> None:
        from omnislam.core.modality import Modality
        from omnislam.estimators import ESTIMATORS

        cells = [c for c in self.grid.cells if c.spec.dataset == dataset]
        track_truth = any(
            c.external is None and Modality.BEARINGS_3D in ESTIMATORS[c.spec.estimator].modalities
            for c in cells
        )
        reporter = self.channel.reporter(PREPARE_KEY + dataset) if self.channel else None
        self._submit(
            "prepare",
            dataset,
            prepare_dataset,
            dataset,
            cells[0].render,
            str(self.logs_dir),
            track_truth,
            reporter,
        )

    def _prepare_label(self, dataset: str) -> str:
        cell = next(c for c in self.grid.cells if c.spec.dataset == dataset)
        if cell.render is not None:
            return f"{cell.render.preset} s{cell.render.seed}"
        return cell.dataset_label

    def _submit_cell(self, cell: Cell) -> None:
        reporter = self.channel.reporter(cell.cell_id) if self.channel is not None else None
        if cell.external is not None:
            self._submit(
                "cell", cell.cell_id, read_external_cell, cell.spec, cell.external, reporter
            )
            return
        self._submit("cell", cell.cell_id, run_cell, self._spec(cell), reporter)

    def _relay(self, finishing: str | None = None) -> None:
        """Pass on what the workers reported of their running cells (and of ``finishing``, the
        cell being collected now)."""
        if self.channel is None or self.on_progress is None:
            return
        running = {key for kind, key in self.running.values() if kind == "cell"} | {finishing}
        preparing = {key for kind, key in self.running.values() if kind == "prepare"}
        for message in self.channel.drain():
            if message.key.startswith(PREPARE_KEY):
                dataset = message.key.removeprefix(PREPARE_KEY)
                if dataset in preparing:  # not one that has finished meanwhile
                    self.announced.add(dataset)
                    self.on_progress(
                        PrepareProgress(
                            dataset,
                            self._prepare_label(dataset),
                            message.stage,
                            message.done,
                            message.total,
                        )
                    )
                continue
            cell = self.by_id.get(message.key)
            # a message that arrives after its cell was collected (the channel's reader thread
            # lags under load) would count the cell's frames a second time: dropped
            if cell is not None and message.key in running:
                self.on_progress(CellProgress(cell, message.stage, message.done, message.total))

    def _spec(self, cell: Cell) -> RunSpec:
        log = self.logs.get(cell.spec.dataset)
        if cell.spec.log is not None or log is None:
            return cell.spec
        return replace(cell.spec, log=log)

    # -- outcomes ------------------------------------------------------------------------
    def _done(self, cell: Cell, outcome: CellOutcome) -> None:
        self.status[cell.cell_id] = outcome.status
        self.finish(outcome)
        for dependent in self.waiting.pop(cell.cell_id, []):
            if outcome.status is CellStatus.FAILED:
                self._done(
                    dependent,
                    CellOutcome(
                        dependent,
                        CellStatus.FAILED,
                        error=f"its prior map, cell {cell.cell_id}, failed",
                    ),
                )
            else:
                self._submit_cell(dependent)

    def _ready(self, dataset: str, log: str | None) -> None:
        """The dataset is prepared: reuse its finished cells, submit the others."""
        self.logs[dataset] = log
        cells = [
            replace(c, spec=self._spec(c)) for c in self.grid.cells if c.spec.dataset == dataset
        ]
        for cell in sorted(cells, key=lambda c: c.prior_from is not None):  # map sources first
            source = cell.prior_from
            if source is not None and self.status.get(source) is not CellStatus.REUSED:
                if self.status.get(source) is CellStatus.FAILED:
                    self._done(
                        cell,
                        CellOutcome(
                            cell, CellStatus.FAILED, error=f"its prior map, cell {source}, failed"
                        ),
                    )
                else:  # computed in this invocation: wait for it, then compute this one too
                    self.waiting.setdefault(source, []).append(cell)
                continue
            reused = (
                _reuse(cell, self.cells_dir / cell.cell_id, self.grid.evaluation)
                if self.reuse and cell.external is None
                else None
            )
            if reused is not None:
                self._done(cell, reused)
            else:
                self.status[cell.cell_id] = CellStatus.COMPUTED  # on its way
                self._submit_cell(cell)

    def _failed(self, kind: str, key: str, error: str, attempts: int) -> None:
        if kind == "cell":
            cell = self.by_id[key]
            self._done(cell, CellOutcome(cell, CellStatus.FAILED, error=error, attempts=attempts))
            return
        for cell in self.grid.cells:
            if cell.spec.dataset == key and cell.cell_id not in self.status:
                self._done(
                    cell,
                    CellOutcome(
                        cell, CellStatus.FAILED, error=f"preparing {key}: {error}", attempts=0
                    ),
                )

    def _collect(self, future: Future) -> None:
        kind, key = self.running.pop(future)
        attempts = self.attempts[(kind, key)]
        if kind == "prepare" and key in self.announced and self.on_progress is not None:
            self.announced.discard(key)
            self.on_progress(PrepareProgress(key, self._prepare_label(key), "done", 0, 0))
        try:
            result = future.result()
        except OmnislamError as exc:  # deterministic: bad option, estimator failure
            self._failed(kind, key, str(exc), 1)
            return
        except BaseException as exc:  # worker lost (killed, pool broken, cancelled)
            if isinstance(exc, KeyboardInterrupt):
                raise
            if attempts < self.max_attempts:
                if kind == "cell":
                    self._submit_cell(self.by_id[key])
                else:
                    self._submit_prepare(key)
            else:
                error = f"{type(exc).__name__}: {exc}".strip()
                self._failed(kind, key, f"gave up after {attempts} attempts ({error})", attempts)
            return
        if kind == "prepare":
            prepared: Prepared = result  # type: ignore[assignment]
            self.warnings.extend(prepared.warnings)
            _say_prepared(prepared)
            self._ready(key, prepared.log)
            return
        record, time_taken, logged = result  # type: ignore[misc]
        self.warnings.extend(logged)
        cell = self.by_id[key]
        if self.on_progress is not None:
            self._relay(finishing=key)  # its last frames before it is stored
            frames = record.config.frames
            self.on_progress(CellProgress(cell, "storing", frames, frames))
        metrics = store_cell(self.cells_dir, cell, record, self.grid.evaluation, time_taken)
        self._done(
            cell,
            CellOutcome(cell, CellStatus.COMPUTED, metrics, attempts=attempts, time=time_taken),
        )

    def run(self) -> None:
        with ExitStack() as stack:
            if self.on_progress is not None:
                self.channel = stack.enter_context(ProgressChannel())
            try:
                for dataset in dict.fromkeys(c.spec.dataset for c in self.grid.cells):
                    self._submit_prepare(dataset)
                while self.running:
                    done, _ = wait(
                        list(self.running),
                        timeout=PROGRESS_POLL_S if self.channel is not None else None,
                        return_when=FIRST_COMPLETED,
                    )
                    self._relay()
                    # futures finished together are stored in submission order (``done`` is a
                    # set): the same grid reports its cells in the same order on every run
                    for future in [f for f in self.running if f in done]:
                        self._collect(future)
            except BaseException:  # interrupted: keep finished cells, do not wait for running
                for future in self.running:
                    future.cancel()
                if self.executor is not None:
                    self.executor.shutdown(wait=False, cancel_futures=True)
                raise
            if self.executor is not None:
                self.executor.shutdown(wait=True)


def _say_prepared(prepared: Prepared) -> None:
    """One line on stderr when a dataset's render or front end was computed now."""
    done = [
        what
        for what, flag in (
            ("rendered", prepared.rendered),
            ("ran the shared front end", prepared.frontend_computed),
            ("computed the true points of its tracks", prepared.truth_computed),
        )
        if flag
    ]
    if done:
        say(
            f"omnislam compare: {prepared.dataset}: {' and '.join(done)} "
            f"({prepared.wall_s:.0f} s wall, {prepared.cpu_s:.0f} s CPU)"
        )
