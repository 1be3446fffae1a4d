"""``benchmarks/suite_rows.py`` splices re-run datasets into a suite report: the result is the
report a full run with the new data would have written, provenance aside."""

from __future__ import annotations

import base64
import importlib.util
import re
import sys
from pathlib import Path

import pytest
import yaml
from room_log import write_room_log

from omnislam.harness.grid import load_grid
from omnislam.harness.runner import SerialExecutor, run_grid
from omnislam.report.comparison import write_report
from omnislam.report.options import ReportOptions

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location("suite_rows", REPO / "benchmarks" / "suite_rows.py")
suite_rows = importlib.util.module_from_spec(_spec)
sys.modules["suite_rows"] = suite_rows
_spec.loader.exec_module(suite_rows)

GRID = """
name: rooms
datasets: [{dataset: data/%s.log, label: b}, {dataset: data/room_a.log, label: a}]
estimators:
  - deadreckoning
  - {estimator: fastslam2, seeds: [0, 1], options: {particles.n_particles: 8}}
evaluation: {rpe_segment_m: 2.0}
"""


def _report(root: Path, name: str, grid: str) -> Path:
    (root / f"{name}.yaml").write_text(grid)
    run_grid(load_grid(root / f"{name}.yaml"), root / f"{name}-results", SerialExecutor)
    write_report(root / f"{name}-results", root / name, ReportOptions(exports=False, figures=False))
    return root / name


@pytest.fixture(scope="module")
def reports(tmp_path_factory) -> tuple[Path, Path, Path]:
    """The old full report (b = room_b), a report of b alone re-run on other data (room_c),
    and the full report with that data (the splice's expected result)."""
    root = tmp_path_factory.mktemp("suite-rows")
    for name, seed in (("room_a", 1), ("room_b", 2), ("room_c", 3)):
        write_room_log(root / "data" / f"{name}.log", frames=120, seed=seed)
    old = _report(root, "old", GRID % "room_b")
    only_b = GRID.replace(", {dataset: data/room_a.log, label: a}", "")
    new = _report(root, "new", only_b % "room_c")
    full = _report(root, "full", GRID % "room_c")
    return old, new, full


def _sections(text: str, heading: str) -> dict[str, str]:
    """A report's sections by their heading's first word, the line that dates it left out."""
    text = re.sub(r"Made with omnislam [^\n]*", "", text)
    assert text.count("Figures: not drawn") == 1
    # the paragraph after the last dataset's section is no part of that section
    text = re.sub(r"(\n|<p>)Figures: not drawn", f"{heading}Trailer: figures", text)
    parts = text.split(heading)
    return {re.match(r"[\w-]+", part).group(0): part for part in parts[1:]} | {"": parts[0]}


def test_the_spliced_report_is_the_full_runs(reports):
    """The whole-suite tables and verdicts are what a full run with the new data reports; each
    dataset's own section is the run that made it (its timings are that run's)."""
    old, new, full = reports
    files = suite_rows.splice_report(old, new, ["b"], "b: re-run")
    for name in ("ate-rmse", "verdict"):
        for ext in (".csv", ".tex"):
            path = Path("tables") / f"{name}{ext}"
            assert files[path] == (full / path).read_text()
            assert files[path] != (old / path).read_text()  # b's numbers did change
    b_tables = sorted(p.name for p in (new / "tables").glob("b-*"))
    assert b_tables and all(files[Path("tables") / n] == (new / "tables" / n).read_text()
                            for n in b_tables)  # fmt: skip
    assert not any(p.name.startswith("a-") for p in files)  # a's own tables are left alone
    for ext, sep in ((".csv", ","), (".tex", " &")):
        spliced = files[Path(f"tables/provenance{ext}")].splitlines()
        old_rows = (old / f"tables/provenance{ext}").read_text().splitlines()
        new_rows = (new / f"tables/provenance{ext}").read_text().splitlines()
        assert [r for r in spliced if r.startswith(f"dataset b{sep}")] == [
            r for r in new_rows if r.startswith(f"dataset b{sep}")
        ]
        assert [r for r in spliced if not r.startswith(("dataset b", "rows re-run"))] == [
            r for r in old_rows if not r.startswith("dataset b")
        ]
        assert spliced[
            spliced.index(next(r for r in spliced if r.startswith(f"runs{sep}"))) + 1
        ] == ("rows re-run,b: re-run" if ext == ".csv" else "rows re-run & b: re-run \\\\")
    for name, heading in (("report.md", "\n## "), ("index.html", "<h2>")):
        spliced = _sections(files[Path(name)], heading)
        expected = _sections((full / name).read_text(), heading)
        assert spliced.keys() == expected.keys()
        for key in expected:
            if key in ("a", "b"):  # a as the old run left it, b as re-run (timings differ)
                source = old if key == "a" else new
                assert spliced[key] == _sections((source / name).read_text(), heading)[key]
            elif key != "Provenance" and not key.startswith("Summary"):  # make suite redraws it
                assert spliced[key] == expected[key], key
        assert "rows re-run" in spliced["Provenance"] and "b: re-run" in spliced["Provenance"]
        assert suite_rows.RE_RUN in files[Path(name)]
    # the inlined copy of the whole-suite table is the spliced one
    page = files[Path("index.html")]
    inlined = [base64.b64decode(b) for b in re.findall(r"base64,([A-Za-z0-9+/=]+)", page)]
    assert files[Path("tables/ate-rmse.csv")].encode() in inlined
    assert (old / "tables/ate-rmse.csv").read_bytes() not in inlined


def test_a_dataset_missing_from_the_new_report_is_refused(reports):
    old, new, _ = reports
    with pytest.raises(suite_rows.SpliceError, match="a"):
        suite_rows.splice_report(old, new, ["a", "b"], "note")


def test_the_subset_grid_keeps_the_matching_datasets_under_their_labels(reports, tmp_path):
    """Labels as ``omnislam compare`` gives them; relative data paths made absolute, so the
    subset grid runs from any folder."""
    root = reports[0].parent
    subset, labels = suite_rows.subset_grid(root / "old.yaml", "^b$")
    assert labels == ["b"] and len(subset["datasets"]) == 1
    entry = subset["datasets"][0]
    assert entry["label"] == "b" and entry["dataset"] == str(root / "data" / "room_b.log")
    assert subset["estimators"] == yaml.safe_load((root / "old.yaml").read_text())["estimators"]
    (tmp_path / "grid.yaml").write_text(yaml.safe_dump(subset))
    assert load_grid(tmp_path / "grid.yaml").datasets == ("b",)
    with pytest.raises(suite_rows.SpliceError, match="no dataset"):
        suite_rows.subset_grid(root / "old.yaml", "^victoria")


def test_a_csv_row_is_laid_out_in_the_old_tables_columns():
    """The re-run datasets' report lacks the min and max columns of an estimator it ran once
    only; its cells are empty there, as the whole report leaves them for such an estimator."""
    old = 'dataset,ground truth,dr,f,f min,f max\na,"x, y",1,2,1.5,3\nb,z,3,4,3.5,5\n'
    new = "dataset,ground truth,dr,f\nb,z,5,6\n"
    spliced = suite_rows.splice_csv(old, new, ["b"], "t")
    assert spliced == 'dataset,ground truth,dr,f,f min,f max\na,"x, y",1,2,1.5,3\nb,z,5,6,,\n'
    with pytest.raises(suite_rows.SpliceError, match="one report only"):
        suite_rows.splice_csv(old, "dataset,ground truth,dr,g\nb,z,5,6\n", ["b"], "t")
    with pytest.raises(suite_rows.SpliceError, match="no row"):
        suite_rows.splice_csv(old, new, ["a", "b"], "t")
