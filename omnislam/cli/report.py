"""``omnislam report RESULTS_DIR --out reports/NAME``: a comparative report of finished runs.

RESULTS_DIR is the folder ``omnislam compare`` wrote, a RUN_DIR, or a folder of RUN_DIRs.
Writes ``report.md`` with its SVGs and a self-contained ``index.html`` (figures inlined): a
verdict per dataset first, the tables and figures, a provenance block last (this command line
included). Every table is also written as ``tables/NAME.csv`` and ``tables/NAME.tex`` (LaTeX
booktabs), plus ``exports/`` (TUM, KITTI, PLY, g2o) unless ``--no-exports``.
"""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("report", help="write an HTML/Markdown report of compared runs")
    p.add_argument("results_dir", metavar="RESULTS_DIR", help="output of `omnislam compare`")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder")
    p.add_argument("--title", default=None, help="report title (default: the grid's name)")
    p.add_argument("--no-exports", action="store_true", help="skip exports/ (TUM, KITTI, PLY)")
    p.add_argument("--no-occupancy", action="store_true", help="skip occupancy grids")
    p.add_argument(
        "--resolution", type=float, default=0.1, metavar="M", help="occupancy cell size [m]"
    )
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from omnislam.compare.report import ReportOptions, write_report
    from omnislam.errors import ConfigError

    if not args.resolution > 0:
        raise ConfigError(f"--resolution must be positive, got {args.resolution}")
    summary = write_report(
        args.results_dir,
        args.out,
        ReportOptions(
            title=args.title,
            exports=not args.no_exports,
            occupancy=not args.no_occupancy,
            occupancy_resolution_m=args.resolution,
        ),
    )
    for note in summary.notes:
        print(f"note: {note}")
    print(
        f"omnislam report: {summary.cells} runs, {len(summary.figures)} figures -> "
        f"{summary.out_dir / 'index.html'} and {summary.out_dir / 'report.md'} "
        f"(tables as CSV and LaTeX in {summary.out_dir / 'tables'})"
    )
    return 0
