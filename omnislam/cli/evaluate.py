"""``omnislam evaluate RUN_DIR [--json]``: metrics against the run's ground truth.

Writes ``RUN_DIR/metrics.json`` (``compare.run_metrics``; null for what is not computed or has
no ground truth) and prints a table, or the JSON with ``--json``.
"""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("evaluate", help="compute metrics of a run against ground truth")
    p.add_argument("run_dir", metavar="RUN_DIR", help="folder written by `omnislam run`")
    p.add_argument("--json", action="store_true", help="print metrics.json instead of a table")
    p.add_argument(
        "--rpe-segment", type=float, default=None, metavar="M", help="RPE segment length [m]"
    )
    p.add_argument(
        "--landmark-gate",
        type=float,
        default=None,
        metavar="M",
        help="landmark association gate for maps without true ids [m]",
    )
    p.set_defaults(handler=run)


def _fmt(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def run(args: argparse.Namespace) -> int:
    import json
    from pathlib import Path

    from omnislam.compare.evaluation import EvaluationOptions, evaluate_run
    from omnislam.compare.run_metrics import write_run_metrics
    from omnislam.compare.rundir import METRICS, read_run_dir
    from omnislam.errors import DataError

    defaults = EvaluationOptions()
    options = EvaluationOptions(
        rpe_segment_m=defaults.rpe_segment_m if args.rpe_segment is None else args.rpe_segment,
        landmark_gate_m=(
            defaults.landmark_gate_m if args.landmark_gate is None else args.landmark_gate
        ),
    )
    path = Path(args.run_dir)
    if not path.is_dir():
        raise DataError("no such RUN_DIR", path)
    record = read_run_dir(path)
    metrics = evaluate_run(record, options)
    write_run_metrics(path / METRICS, metrics)
    if args.json:
        print(json.dumps(metrics.to_json(), indent=2))
        return 0
    config = record.config
    print(f"{config.estimator} on {config.dataset} ({config.frames} frames)")
    if metrics.ate.rmse_m is None:
        print(
            f"no ground truth ({record.ground_truth.kind.value}): "
            f"{record.ground_truth.note or 'nothing to compare against'}"
        )
    else:
        kind, note = record.ground_truth.kind.value, record.ground_truth.note
        # notes usually begin with their kind ("exact: the renderer's own poses ...")
        print(f"ground truth: {note if note.startswith(kind) else f'{kind}: {note}'}")
    ate, rpe, landmarks, timing = metrics.ate, metrics.rpe, metrics.landmarks, metrics.timing
    rows = [
        ("ATE RMSE, SE(2) aligned [m]", ate.rmse_m),
        ("ATE max, SE(2) aligned [m]", ate.max_m),
        ("ATE RMSE, origin aligned [m]", ate.origin_rmse_m),
        ("ATE max, origin aligned [m]", ate.origin_max_m),
        (
            "poses compared / coverage",
            None
            if ate.matched is None or ate.coverage is None
            else f"{ate.matched} / {ate.coverage:.1%}",
        ),
        (f"RPE {options.rpe_segment_m:g} m trans RMSE [m]", rpe.trans_rmse_m),
        (f"RPE {options.rpe_segment_m:g} m rot RMSE [deg]", rpe.rot_rmse_deg),
        ("landmark RMSE [m]", landmarks.rmse_m),
        (
            "landmarks estimated / matched / true",
            f"{landmarks.estimated} / {_fmt(landmarks.matched)} / {_fmt(landmarks.truth)}",
        ),
        ("pose NEES mean (dof 3 when consistent)", metrics.nees.pose_mean),
        ("landmark NEES mean", metrics.nees.landmark_mean),
        (
            "step median / p95 [ms]",
            f"{_fmt(timing.step_median_ms)} / {_fmt(timing.step_p95_ms)}",
        ),
        ("total [s]", timing.total_s),
        ("peak RSS [MB]", timing.peak_rss_mb),
    ]
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"  {name.ljust(width)}  {_fmt(value)}")
    print(f"-> {path / METRICS}")
    return 0
