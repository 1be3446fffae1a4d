"""Run the embedded demo end to end.

Renders the demo world, runs the shared front end, every available estimator and the report,
each step with its progress on stderr (images rendered and processed, frames stepped by each
estimator, the report's datasets); the work folder (--work) is a cache that later runs reuse
when its inputs are unchanged. The last line names the report. An existing report folder is
replaced only with --overwrite (make demo passes it).
"""

from __future__ import annotations

import argparse
import sys
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from omnislam._progress import Progress
    from omnislam.harness.grid import Grid
    from omnislam.harness.grid_progress import GridProgress
    from omnislam.harness.runner import CellOutcome, CellProgress, PrepareProgress


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="render the demo world, run the front end and every estimator, write a report",
        description=__doc__,
    )
    p.add_argument("--out", default="reports/demo", help="report folder (default reports/demo)")
    p.add_argument(
        "--work", default="runs/demo", help="work folder: data, front-end log, runs (runs/demo)"
    )
    p.add_argument("--seed", type=int, default=0, help="world, noise and estimator seed")
    p.add_argument("--workers", type=int, default=None, help="processes for the estimators")
    p.add_argument("--overwrite", action="store_true", help="replace an existing report folder")
    p.set_defaults(handler=run)


class DemoProgress:
    """The progress lines of the demo's estimator and report stages (a context manager)."""

    def __init__(self) -> None:
        self._grid: GridProgress | None = None
        self._report: Progress | None = None

    def on_grid(self, grid: Grid) -> None:
        from omnislam.harness.grid_progress import GridProgress

        self._grid = GridProgress(grid, "demo estimators")

    def on_outcome(self, outcome: CellOutcome) -> None:
        if self._grid is not None:
            self._grid.on_outcome(outcome)

    def on_progress(self, progress: CellProgress | PrepareProgress) -> None:
        if self._grid is not None:
            self._grid.on_progress(progress)

    def report_step(self, stage: str, done: int, total: int) -> None:
        from omnislam._progress import Progress

        if self._report is None:
            if self._grid is not None:
                self._grid.close()
                self._grid = None
            self._report = Progress("demo report", None, "dataset")
        self._report.update(done, total=total or None, doing=stage)

    def __enter__(self) -> DemoProgress:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        trace: TracebackType | None,
    ) -> None:
        if self._grid is not None:
            self._grid.__exit__(kind, value, trace)
        if self._report is not None:
            self._report.__exit__(kind, value, trace)


def run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from omnislam._files import check_overwrite
    from omnislam.demo import run_demo
    from omnislam.harness.runner import local_executor_factory
    from omnislam.report.comparison import REPORT_MD, check_report_dir

    start = time.perf_counter()
    out = Path(args.out)
    check_report_dir(out)
    check_overwrite(out, args.overwrite, "report folder", lambda p: (p / REPORT_MD).is_file())
    if args.workers is not None:
        local_executor_factory(args.workers)  # a bad --workers fails before the rendering
    with DemoProgress() as progress:
        result = run_demo(
            out,
            Path(args.work),
            seed=args.seed,
            workers=args.workers,
            on_outcome=progress.on_outcome,
            on_progress=progress.on_progress,
            on_grid=progress.on_grid,
            report_step=progress.report_step,
        )
    for warning in result.results.warnings:  # each once, after the progress lines
        warning.log()
    print(f"{'estimator':16s} {'ATE RMSE [m]':>12s} {'landmark RMSE [m]':>18s} {'status':>9s}")
    for outcome in result.results.outcomes:
        metrics = outcome.metrics
        ate = _number(metrics.ate.rmse_m if metrics is not None else None)
        lm = _number(metrics.landmarks.rmse_m if metrics is not None else None)
        print(f"{outcome.cell.spec.estimator:16s} {ate:>12s} {lm:>18s} {outcome.status.value:>9s}")
        if outcome.error:
            print(f"  {outcome.error}", file=sys.stderr)
    for name in result.skipped_estimators:
        print(f"{name:16s} not available in this installation", file=sys.stderr)
    page = result.report.out_dir / "index.html"
    print(
        f"omnislam demo: report {page} ({time.perf_counter() - start:.0f} s); open it with "
        f"a browser (file://{page.resolve()})"
    )
    return 0


def _number(value: float | None) -> str:
    return f"{value:.4f}" if value is not None else "-"
