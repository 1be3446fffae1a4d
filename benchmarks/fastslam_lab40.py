"""FastSLAM's 3-D (omni bearings) mode on a front-end log: estimator x bearing update.

Cells: FastSLAM 1.0 and 2.0 (presets ``fastslam1``: 100 particles, ``fastslam2``: 20) with the
thesis's triangulated landmark update (Guizilini 2008 eqs. 4.21, 4.25-4.37: a new ray is
triangulated with the stored previous sighting and the point is used as a range-azimuth-elevation
measurement) and with the direct 2-DOF azimuth/elevation EKF update (``BearingUpdate``), plus
dead reckoning as the floor to beat. Each cell replays the same observation log
(``omnislam run DATASET --log LOG --set modality=bearings-3d``) and is evaluated like
``omnislam evaluate RUN --rpe-segment 5 --landmark-gate 0.3``. With ``--mrclam`` the 2-D
range-bearing reference (MR.CLAM dataset 6, robot 1) is run too.

Printed per cell and seed: ATE RMSE (SE(2)-aligned), landmark RMSE and median (landmarks carry
the track ids, compared with the true 3-D points of the tracks), landmarks estimated per true
landmark, and the estimator's run time (sum of its step times; the machine's load shows here)::

    .venv/bin/python benchmarks/fastslam_lab40.py [--dataset runs/lab40] \
        [--log runs/lab40-results/logs/benchmarks-grids-..-..-runs-lab40.npz] [--seeds 0 1 2] \
        [--set proposal.max_sightings=20] [--mrclam]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from harness_cells import add_set_option, set_options

from omnislam.harness.evaluation import EvaluationOptions, evaluate_run
from omnislam.harness.execute import RunSpec, execute_run

DEFAULT_DATASET = "runs/lab40"
DEFAULT_LOG = "runs/lab40-results/logs/benchmarks-grids-..-..-runs-lab40.npz"
MRCLAM = "mrclam6-r1"
EVALUATION = EvaluationOptions(rpe_segment_m=5.0, landmark_gate_m=0.3)


@dataclass(frozen=True, slots=True)
class Cell:
    """One configuration: estimator name and its ``--set`` options."""

    label: str
    estimator: str
    options: dict[str, str]


@dataclass(frozen=True, slots=True)
class Row:
    """One evaluated run."""

    cell: Cell
    seed: int
    ate_m: float
    landmark_rmse_m: float | None
    landmark_median_m: float | None
    per_true: float | None
    run_s: float


def omni_cells(extra: dict[str, str]) -> list[Cell]:
    """Dead reckoning, then fastslam1/fastslam2 x triangulated/direct on the bearings log."""
    cells = [Cell("deadreckoning", "deadreckoning", {})]
    for estimator in ("fastslam1", "fastslam2"):
        for update in ("triangulated", "direct"):
            options = {"modality": "bearings-3d", "bearings.update": update, **extra}
            cells.append(Cell(f"{estimator} {update}", estimator, options))
    return cells


def mrclam_cells() -> list[Cell]:
    """The 2-D range-bearing reference."""
    return [
        Cell(f"{name} (MR.CLAM)", name, {}) for name in ("deadreckoning", "fastslam1", "fastslam2")
    ]


def run_cell(cell: Cell, dataset: str, log: str | None, seed: int) -> Row:
    """Run and evaluate one cell."""
    record = execute_run(RunSpec(dataset, cell.estimator, seed, cell.options, log))
    metrics = evaluate_run(record, EVALUATION)
    landmarks = metrics.landmarks
    estimated, true = landmarks.estimated, landmarks.truth
    per_true = estimated / true if estimated and true else None
    return Row(
        cell,
        seed,
        float(metrics.ate.rmse_m),
        landmarks.rmse_m,
        landmarks.median_m,
        per_true,
        float(record.config.total_s),
    )


def _fmt(value: float | None, width: int, digits: int) -> str:
    return f"{'-':>{width}s}" if value is None else f"{value:{width}.{digits}f}"


HEADER = (
    f"{'cell':28s} {'seed':>4s} {'ATE [m]':>8s} {'lm RMSE [m]':>11s} {'lm median':>9s} "
    f"{'lm/true':>7s} {'run [s]':>8s}"
)


def print_row(row: Row) -> None:
    print(
        f"{row.cell.label:28s} {row.seed:4d} {row.ate_m:8.4f} "
        f"{_fmt(row.landmark_rmse_m, 11, 4)} {_fmt(row.landmark_median_m, 9, 4)} "
        f"{_fmt(row.per_true, 7, 3)} {row.run_s:8.1f}",
        flush=True,
    )


def print_medians(rows: list[Row]) -> None:
    """Median of each column over the seeds, per cell."""
    print("\nmedians over seeds")
    labels = list(dict.fromkeys(row.cell.label for row in rows))
    for label in labels:
        sel = [row for row in rows if row.cell.label == label]

        def median(values: list[float | None]) -> float | None:
            kept = [v for v in values if v is not None]
            return float(np.median(kept)) if kept else None

        print(
            f"{label:28s} {'':4s} {median([r.ate_m for r in sel]):8.4f} "
            f"{_fmt(median([r.landmark_rmse_m for r in sel]), 11, 4)} "
            f"{_fmt(median([r.landmark_median_m for r in sel]), 9, 4)} "
            f"{_fmt(median([r.per_true for r in sel]), 7, 3)} "
            f"{median([r.run_s for r in sel]):8.1f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=DEFAULT_DATASET, help="synthetic world folder")
    parser.add_argument("--log", default=DEFAULT_LOG, help="its front-end observation log")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0])
    add_set_option(parser, "extra FastSLAM option for every bearings cell (repeatable)")
    parser.add_argument("--mrclam", action="store_true", help=f"also run {MRCLAM} (2-D)")
    parser.add_argument("--only", default=None, help="run only cells whose label contains this")
    args = parser.parse_args()
    extra = set_options(parser, args.options)
    dataset = str(Path(args.dataset).resolve())
    log = str(Path(args.log).resolve())

    jobs: list[tuple[Cell, str, str | None]] = [(c, dataset, log) for c in omni_cells(extra)]
    if args.mrclam:
        jobs += [(c, MRCLAM, None) for c in mrclam_cells()]
    if args.only:
        jobs = [job for job in jobs if args.only in job[0].label]
    print(f"dataset {dataset}\nlog     {log}\nextra options {extra or 'none'}\n")
    print(HEADER)
    rows = []
    for cell, data, cell_log in jobs:
        for seed in args.seeds:
            print(f"  running {cell.label} seed {seed} ...", file=sys.stderr, flush=True)
            row = run_cell(cell, data, cell_log, seed)
            rows.append(row)
            print_row(row)
    if len(args.seeds) > 1:
        print_medians(rows)


if __name__ == "__main__":
    main()
