"""Write a comparative report of finished runs.

RESULTS_DIR is the folder omnislam compare wrote, a RUN_DIR, or a folder of RUN_DIRs. Writes
report.md with its SVGs and a self-contained index.html (figures inlined): a verdict per dataset
first, the tables and figures, a provenance block last (this command line included). Every
table is also written as tables/NAME.csv and tables/NAME.tex (LaTeX booktabs), plus exports/
(TUM, KITTI, PLY, g2o) unless --no-exports; --no-figures leaves out each dataset's figures and
keeps the summary figures (a report of many datasets small enough to commit). An existing report
folder is replaced only with --overwrite. Progress goes to stderr; the last line names the
report.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from omnislam.report.comparison import ReportSummary
    from omnislam.report.options import ReportOptions


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report", help="write an HTML/Markdown report of compared runs", description=__doc__
    )
    p.add_argument("results_dir", metavar="RESULTS_DIR", help="output of `omnislam compare`")
    p.add_argument("--out", required=True, metavar="DIR", help="report folder")
    p.add_argument("--title", default=None, help="report title (default: the grid's name)")
    p.add_argument("--no-exports", action="store_true", help="skip exports/ (TUM, KITTI, PLY, g2o)")
    p.add_argument(
        "--no-figures",
        action="store_true",
        help="verdicts, tables and the summary figures only (a small report)",
    )
    p.add_argument("--no-occupancy", action="store_true", help="skip occupancy grids")
    p.add_argument(
        "--resolution", type=float, default=0.1, metavar="M", help="occupancy cell size [m]"
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing report folder")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from omnislam._files import check_overwrite
    from omnislam.errors import ConfigError
    from omnislam.report.comparison import REPORT_MD, check_report_dir
    from omnislam.report.options import ReportOptions

    if not args.resolution > 0:
        raise ConfigError(f"--resolution must be positive, got {args.resolution}")
    check_report_dir(Path(args.out))
    check_overwrite(args.out, args.overwrite, "report folder", lambda p: (p / REPORT_MD).is_file())
    summary = write_report_with_progress(
        args.results_dir,
        args.out,
        ReportOptions(
            title=args.title,
            exports=not args.no_exports,
            figures=not args.no_figures,
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


def write_report_with_progress(
    results_dir: str | Path, out: str | Path, options: ReportOptions
) -> ReportSummary:
    """``write_report`` with one progress line on stderr (datasets done, what is being made)."""
    from dataclasses import replace

    from omnislam._progress import Progress
    from omnislam.report.comparison import write_report

    with Progress(f"report {Path(str(out)).name}", None, "dataset") as bar:

        def on_step(stage: str, done: int, total: int) -> None:
            bar.update(done, total=total or None, doing=stage)

        bar.update(doing="reading the runs")
        return write_report(results_dir, out, replace(options, on_step=on_step))
