"""``benchmarks/suite_table.py`` regenerates the README's results table from a report."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.harness.grid import load_grid
from omnislam.harness.runner import SerialExecutor, run_grid
from omnislam.report.comparison import write_report
from omnislam.report.options import ReportOptions

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "suite_table", REPO / "benchmarks" / "suite_table.py"
)
suite_table = importlib.util.module_from_spec(_spec)
sys.modules["suite_table"] = suite_table  # dataclasses look their module up
_spec.loader.exec_module(suite_table)

GRID = """
name: rooms
datasets: [data/room_a.log, {dataset: data/room_b.log, label: b}]
estimators:
  - deadreckoning
  - {estimator: fastslam2, seeds: [0, 1], options: {particles.n_particles: 8}}
evaluation: {rpe_segment_m: 2.0}
"""
README = "# x\n\nintro\n\n<!-- suite-table:begin -->\nstale\n<!-- suite-table:end -->\n\nrest\n"


@pytest.fixture(scope="module")
def small_report(tmp_path_factory) -> tuple[Path, object]:
    root = tmp_path_factory.mktemp("suite-table")
    write_room_log(root / "data" / "room_a.log", frames=120, seed=1)
    write_room_log(root / "data" / "room_b.log", frames=120, seed=2)
    (root / "grid.yaml").write_text(GRID)
    result = run_grid(load_grid(root / "grid.yaml"), root / "results", SerialExecutor)
    # as make suite writes it: no figures (the suite's report must stay small enough to commit)
    write_report(root / "results", root / "report", ReportOptions(exports=False, figures=False))
    return root / "report", result


def test_the_table_is_the_reports_numbers_with_each_rows_verdict(small_report, tmp_path):
    report, result = small_report
    readme = tmp_path / "README.md"
    readme.write_text(README)
    assert suite_table.main(["--report", str(report), "--readme", str(readme)]) == 0
    text = readme.read_text()
    assert text.startswith("# x\n\nintro\n\n<!-- suite-table:begin -->\n| dataset |")
    assert text.endswith("|\n<!-- suite-table:end -->\n\nrest\n") and "stale" not in text
    block = text.split(suite_table.BEGIN)[1].split(suite_table.END)[0].strip().splitlines()
    assert block[0].split(" | ")[2:4] == ["deadreckoning", "fastslam2"]
    rows = {line.split(" | ")[0].lstrip("| "): line.split(" | ") for line in block[2:]}
    assert set(rows) == {"room_a", "b"}
    for dataset, row in rows.items():
        ate = {
            (o.cell.estimator_label, o.cell.spec.seed): o.metrics.ate.rmse_m
            for o in result.outcomes
            if o.cell.dataset_label == dataset
        }
        assert row[2] == f"{ate[('deadreckoning', 0)]:.3g}"
        filters = sorted([ate[("fastslam2", 0)], ate[("fastslam2", 1)]])
        median, low, high = filters[0], filters[0], filters[1]  # the low median of two seeds
        # the only ranked estimator is the best (bold), with no runner-up
        assert row[3] == f"**{median:.3g} [{low:.3g}–{high:.3g}]**"
        # the verdict's median, and whether dead reckoning's median is below it
        dead = ate[("deadreckoning", 0)]
        behind = f"; dead reckoning's {dead:.3g} is lower" if median > dead else ""
        assert row[4] == f"fastslam2 {median:.3g} (one family ranked{behind}) |"
    assert suite_table.main(["--report", str(report), "--readme", str(readme), "--check"]) == 0


def test_the_suites_report_has_its_tables_and_only_the_summary_figures(small_report):
    report, _ = small_report
    assert sorted(p.name for p in report.glob("*.svg")) == [
        "accuracy-vs-time.svg",
        "b-ate-by-input.svg",
        "families.svg",
        "room_a-ate-by-input.svg",
    ]
    assert "Figures: not drawn for this report" in (report / "report.md").read_text()
    assert {"ate-rmse.csv", "verdict.csv", "room_a-metrics.csv", "b-metrics.csv"} <= {
        p.name for p in (report / "tables").iterdir()
    }


def test_check_fails_on_a_stale_table_and_bad_input_exits_2(small_report, tmp_path, capsys):
    report, _ = small_report
    readme = tmp_path / "README.md"
    readme.write_text(README)
    assert suite_table.main(["--report", str(report), "--readme", str(readme), "--check"]) == 1
    assert readme.read_text() == README  # --check writes nothing
    readme.write_text("# no markers\n")
    assert suite_table.main(["--report", str(report), "--readme", str(readme)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        err[-1]
        == f"suite_table: {readme}: no block between {suite_table.BEGIN} and {suite_table.END}"
    )
    assert suite_table.main(["--report", str(tmp_path / "none"), "--readme", str(readme)]) == 2
    assert "ate-rmse.csv: cannot read" in capsys.readouterr().err


def test_the_committed_tables_are_the_committed_suite_reports():
    """The README's and the suite page's tables are what the committed report gives, whichever
    format it was written in (a report of format 1 has one verdict row per dataset)."""
    report = REPO / "reports" / "suite"
    for page in ("README.md", "docs/results/index.md"):
        args = ["--report", str(report), "--readme", str(REPO / page), "--check"]
        assert suite_table.main(args) == 0, page
