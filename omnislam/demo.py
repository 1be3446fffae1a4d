"""``omnislam demo``: the embedded default, end to end.

1. render the synthetic ``demo`` world (about 60 catadioptric frames, exact ground truth) into a
   work folder, unless it is already there;
2. run the shared front end once (SIFT on the omni images, groups, verified matching, tracks)
   and cache its ObservationLog;
3. replay that log to every available estimator (dead reckoning, iSAM2, batch LM, FastSLAM 1.0,
   2.0, EKF-SLAM and the vertical-line UKF) through the grid runner, with the ground truth of
   the renderer;
4. write the comparison report (``index.html`` with embedded figures, ``report.md``).

Every step reuses what an earlier run left in the work folder when its inputs are unchanged.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from omnislam.harness.grid import Grid, parse_grid
from omnislam.harness.runner import (
    CellOutcome,
    CellProgress,
    GridResult,
    PrepareProgress,
    local_executor_factory,
    run_grid,
)
from omnislam.report.comparison import ReportSummary, write_report
from omnislam.report.options import ReportOptions

#: the estimators the demo compares, in report order (unavailable ones are skipped)
#: (each consumes the stream the one modality rule picks: the omni bearings of the front end for
#: the graphs and FastSLAM, the pole sightings for EKF-SLAM, which takes range-bearing only, the
#: vertical lines for the UKF, which localises in the world's 2-D map)
DEMO_ESTIMATORS = (
    "deadreckoning",
    "graphslam",
    "graphslam-batch",
    "fastslam1",
    "fastslam2",
    "ekfslam",
    "ukf",
)


@dataclass(frozen=True, slots=True)
class DemoResult:
    """What ``run_demo`` produced."""

    dataset: Path
    results: GridResult
    report: ReportSummary
    skipped_estimators: tuple[str, ...]


def available_estimators(names: tuple[str, ...] = DEMO_ESTIMATORS) -> tuple[list[str], list[str]]:
    """Split ``names`` into (available, unavailable) estimators of this installation."""
    from omnislam.errors import OmnislamError
    from omnislam.harness.execute import check_estimator

    available, skipped = [], []
    for name in names:
        try:
            check_estimator(name)
        except OmnislamError:
            skipped.append(name)
        else:
            available.append(name)
    return available, skipped


def render_demo(folder: Path, seed: int) -> Path:
    """Render the ``demo`` preset into ``folder`` unless a synthetic folder is already there."""
    from omnislam.datasets.synthetic import cli_synth, is_synthetic_folder

    if not is_synthetic_folder(folder):
        args = argparse.Namespace(
            preset="demo", out=str(folder), seed=seed, frames=None, backend=None, overwrite=True
        )
        cli_synth(args)
    return folder


def demo_grid(dataset: Path, estimators: list[str], seed: int) -> Grid:
    """The demo's grid: one dataset, the given estimators, one seed."""
    import yaml

    spec = {
        "name": "omnislam demo (synthetic omni world)",
        "datasets": [{"dataset": str(dataset.resolve()), "label": "demo"}],
        "estimators": [
            {"estimator": name, "options": {}} for name in estimators
        ],
        "seeds": [seed],
        "evaluation": {"rpe_segment_m": 1.0, "landmark_gate_m": 0.3},
    }
    return parse_grid(yaml.safe_dump(spec, sort_keys=False), dataset.parent / "demo-grid.yaml")


def run_demo(
    out: Path,
    work: Path,
    *,
    seed: int = 0,
    workers: int | None = None,
    on_outcome: Callable[[CellOutcome], None] | None = None,
    on_progress: Callable[[CellProgress | PrepareProgress], None] | None = None,
    on_grid: Callable[[Grid], None] | None = None,
    report_step: Callable[[str, int, int], None] | None = None,
) -> DemoResult:
    """Render, run the front end, every estimator, evaluate and report (see module docstring).

    Args:
        out: report folder (replaced atomically).
        work: folder for the rendered dataset, the front-end log and the runs (kept for reuse).
        seed: world and noise seed of the rendering and of the estimators.
        workers: processes for the estimators (default: the number of cores).
        on_outcome: called as each estimator finishes (progress).
        on_progress: called with what the running estimators are doing (frames stepped).
        on_grid: called with the demo's grid before it runs (to set up a progress line).
        report_step: progress of the report (``ReportOptions.on_step``).
    """
    work.mkdir(parents=True, exist_ok=True)
    dataset = render_demo(work / f"demo-seed{seed}", seed)
    estimators, skipped = available_estimators()
    grid = demo_grid(dataset, estimators, seed)
    if on_grid is not None:
        on_grid(grid)
    factory = local_executor_factory(workers if workers is not None else os.cpu_count() or 1)
    results = run_grid(
        grid, work / "results", factory, on_outcome=on_outcome, on_progress=on_progress
    )
    report = write_report(
        work / "results",
        out,
        ReportOptions(title="omnislam demo: synthetic omni world", on_step=report_step),
    )
    return DemoResult(dataset, results, report, tuple(skipped))
