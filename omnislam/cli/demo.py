"""``omnislam demo [--out DIR]``: the embedded default, end to end (see compare/demo.py)."""

from __future__ import annotations

import argparse
import sys


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "demo",
        help="render the demo world, run the front end and every estimator, write a report",
    )
    p.add_argument("--out", default="reports/demo", help="report folder (default reports/demo)")
    p.add_argument(
        "--work", default="runs/demo", help="work folder: data, front-end log, runs (runs/demo)"
    )
    p.add_argument("--seed", type=int, default=0, help="world, noise and estimator seed")
    p.add_argument("--workers", type=int, default=None, help="processes for the estimators")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    import time
    from pathlib import Path

    from tqdm import tqdm

    from omnislam.compare.demo import available_estimators, run_demo

    start = time.perf_counter()
    estimators, _ = available_estimators()
    with tqdm(total=len(estimators), desc="estimators", unit="run", file=sys.stderr) as bar:
        result = run_demo(
            Path(args.out),
            Path(args.work),
            seed=args.seed,
            workers=args.workers,
            on_outcome=lambda _: bar.update(),
        )
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
    print(
        f"omnislam demo: report {result.report.out_dir / 'index.html'} "
        f"({time.perf_counter() - start:.0f} s)"
    )
    return 0


def _number(value: float | None) -> str:
    return f"{value:.4f}" if value is not None else "-"
