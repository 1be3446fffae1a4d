"""The report's verdict, provenance block and publication tables (CSV and LaTeX booktabs).

Two fake estimators (``report_fakes``: dead reckoning plus a wobble of a chosen size) run on
the room log over two seeds, so the expected verdict is known from the cells' own metrics.
"""

from __future__ import annotations

import csv
import io
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from room_log import write_room_log
from small_mrclam import write_small_mrclam

import omnislam
from omnislam.harness.grid import parse_grid
from omnislam.harness.runner import SerialExecutor, run_grid
from omnislam.report import provenance
from omnislam.report.comparison import write_report
from omnislam.report.options import ReportOptions
from omnislam.report.tables import latex_escape

FAST = ReportOptions(exports=False, occupancy=False, command=("omnislam", "report", "R"))
# a number standing alone (not the digits inside a commit hash such as 3d2a412fbcdc4b032e41445...)
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e[+-]?\d+)?(?![\w.])")


@pytest.fixture
def fakes(monkeypatch):
    import omnislam.estimators as registry

    for name in ("tidy_odo", "rough_odo"):
        monkeypatch.setitem(
            registry.ESTIMATORS,
            name,
            registry.EstimatorEntry(
                "report_fakes:make_wobbly",
                frozenset(),
                stochastic=True,
                family=registry.Family.PARTICLE_FILTER
                if name == "tidy_odo"
                else registry.Family.FACTOR_GRAPH,
            ),
        )


def run_room_grid(tmp_path: Path, tidy: dict, rough: dict, name: str,
                  labels: tuple[str, str] | None = None) -> Path:
    """The two fakes and dead reckoning on the room log, seeds 0 and 1 (the fakes' columns
    named ``labels`` when given)."""
    data = tmp_path / "data" / "room.log"
    if not data.exists():
        write_room_log(data, frames=60)
    fakes = [{"estimator": "tidy_odo", "options": tidy},
             {"estimator": "rough_odo", "options": rough}]
    for entry, label in zip(fakes, labels or (), strict=False):
        entry["label"] = label
    grid = {
        "name": name,
        "datasets": ["data/room.log"],
        "estimators": ["deadreckoning", *fakes],
        "seeds": [0, 1],
    }
    out = tmp_path / f"results-{name}"
    run_grid(parse_grid(json.dumps(grid), tmp_path / "grid.yaml"), out, SerialExecutor)
    return out


def ate_by_column(results: Path) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for row in json.loads((results / "results.json").read_text())["cells"]:
        assert row["status"] != "failed", row["error"]
        out.setdefault(row["column"], []).append(row["metrics"]["ate_rmse_m"])
    return out


def md_tables(md: str) -> dict[str, tuple[list[str], list[list[str]]]]:
    """Each Markdown table of the report by the name of the CSV linked under it."""
    tables, lines = {}, md.splitlines()
    for i, line in enumerate(lines):
        link = re.match(r"\*Table as \[CSV\]\(tables/([^)]+)\.csv\)", line)
        if not link:
            continue
        end = i - 1 if lines[i - 1] == "" else i
        start = end
        while start > 0 and lines[start - 1].startswith("|"):
            start -= 1
        rows = [[c.strip() for c in re.split(r"(?<!\\)\|", r)[1:-1]] for r in lines[start:end]]
        tables[link.group(1)] = (rows[0], rows[2:])
    return tables


def tolerance(token: str) -> float:
    """Half a unit in the last digit shown."""
    mantissa, _, exponent = token.lower().partition("e")
    decimals = len(mantissa.partition(".")[2])
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals) * (1 + 1e-9)


def verdict_rows(report: Path) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO((report / "tables" / "verdict.csv").read_text())))


def low_median(values: list[float]) -> float:
    return sorted(values)[(len(values) - 1) // 2]


def test_verdict_names_the_best_family_and_the_margin_behind_it(fakes, tmp_path):
    results = run_room_grid(
        tmp_path, {"amplitude": 0.02}, {"amplitude": 0.5, "seed_gain": 0.2}, "clear"
    )
    ate = ate_by_column(results)
    medians = {col: low_median(v) for col, v in ate.items() if col != "deadreckoning"}
    best, runner = sorted(medians, key=medians.get)
    assert best == "tidy_odo"  # by construction; the verdict must follow the numbers
    margin = medians[runner] - medians[best]
    assert max(ate[best]) < min(ate[runner])  # constructed: the ranges do not overlap
    write_report(results, tmp_path / "report", FAST)
    md = (tmp_path / "report" / "report.md").read_text()
    assert md.index("## Verdict") < md.index("## ATE RMSE")
    first, second = verdict_rows(tmp_path / "report")
    assert (first["best"], second["best"]) == (best, runner)
    assert (first["family"], second["family"]) == ("particle filter", "factor graph")
    assert float(second["behind the best [m]"]) == pytest.approx(margin, rel=1e-12)
    assert float(first["min [m]"]) == pytest.approx(min(ate[best]))
    assert float(second["max [m]"]) == pytest.approx(max(ate[runner]))
    assert float(first["dead reckoning median [m]"]) == pytest.approx(ate["deadreckoning"][0])
    assert second["separated from the best"] == "yes"
    shown = md_tables(md)["verdict"][1]
    assert shown[1][5] == f"+{margin:.3g} m ({100 * margin / medians[runner]:.0f} %)"


def test_a_labelled_column_keeps_its_estimators_family(fakes, tmp_path):
    """A grid's label (``ekfslam-poles`` for ekfslam on the pole sightings) names a column, not
    an estimator: the verdict ranks the column in its estimator's family, not as another
    system's results."""
    out = run_room_grid(tmp_path, {"amplitude": 0.02}, {"amplitude": 0.5}, "labels",
                        labels=("tidy-labelled", "rough-labelled"))
    write_report(out, tmp_path / "report", FAST)
    families = {row["best"]: row["family"] for row in verdict_rows(tmp_path / "report")}
    assert families == {"tidy-labelled": "particle filter", "rough-labelled": "factor graph"}


def test_overlapping_seed_ranges_and_one_seed_are_told_in_the_notes(fakes, tmp_path):
    results = run_room_grid(
        tmp_path,
        {"amplitude": 0.3, "seed_gain": 1.0},
        {"amplitude": 0.31, "seed_gain": 1.0},
        "close",
    )
    ate = ate_by_column(results)
    tidy, rough = ate["tidy_odo"], ate["rough_odo"]
    best, runner = (
        ("tidy_odo", "rough_odo")
        if low_median(tidy) <= low_median(rough)
        else ("rough_odo", "tidy_odo")
    )
    assert max(ate[best]) >= min(ate[runner])  # constructed: the seed ranges overlap
    write_report(results, tmp_path / "report", FAST)
    md = (tmp_path / "report" / "report.md").read_text()
    assert f"- room (odometry): {best}'s and {runner}'s ranges over seeds overlap" in md
    assert verdict_rows(tmp_path / "report")[1]["separated from the best"] == "no"

    single = tmp_path / "one-seed"
    single.mkdir()
    for column in ("tidy_odo", "rough_odo"):
        shutil.copytree(results / "cells" / f"room__{column}__s0", single / column)
    write_report(single, tmp_path / "report1", FAST)
    md = (tmp_path / "report1" / "report.md").read_text()
    assert "one seed of a seed-dependent estimator" in md
    assert verdict_rows(tmp_path / "report1")[1]["separated from the best"] == "unknown (1 seed)"


def test_every_place_a_cell_appears_gives_the_same_median_and_range(fakes, tmp_path):
    data = tmp_path / "data" / "room.log"
    write_room_log(data, frames=60)
    grid = {
        "name": "three",
        "datasets": ["data/room.log"],
        "estimators": [
            "deadreckoning",
            {"estimator": "tidy_odo", "options": {"amplitude": 0.05, "seed_gain": 1.0}},
            {"estimator": "rough_odo", "options": {"amplitude": 0.3, "seed_gain": 1.0}},
        ],
        "seeds": [0, 1, 2],
    }
    results = tmp_path / "results"
    run_grid(parse_grid(json.dumps(grid), tmp_path / "grid.yaml"), results, SerialExecutor)
    write_report(results, tmp_path / "report", FAST)
    report = tmp_path / "report"
    ate = ate_by_column(results)
    assert len(ate["deadreckoning"]) == 1 and len(ate["tidy_odo"]) == 3  # run once vs per seed
    md_shown = md_tables((report / "report.md").read_text())
    html = (report / "index.html").read_text()

    def csv_rows(name: str) -> list[dict[str, str]]:
        return list(csv.DictReader(io.StringIO((report / "tables" / f"{name}.csv").read_text())))

    for column in ("tidy_odo", "rough_odo"):
        values = sorted(ate[column])
        median, low, high = values[1], values[0], values[2]
        text = f"{median:.3g} [{low:.3g}–{high:.3g}]"
        # Markdown: the headline, the dataset's table and the verdict show the same text
        header, rows = md_shown["ate-rmse"]
        assert rows[0][header.index(column)] == text
        header, rows = md_shown["room-metrics"]
        assert next(r for r in rows if r[0] == column)[1] == text
        assert any(r[3] == column and r[4] == text for r in md_shown["verdict"][1])
        # HTML: the same cells
        assert html.count(f">{text}</td>") >= 3
        # CSV: the same numbers at full precision
        headline = csv_rows("ate-rmse")[0]
        assert [float(headline[f"{column}{s}"]) for s in ("", " min", " max")] == [
            pytest.approx(v, rel=1e-12) for v in (median, low, high)
        ]
        metrics = next(r for r in csv_rows("room-metrics") if r["estimator"] == column)
        assert float(metrics["ATE RMSE [m]"]) == pytest.approx(median, rel=1e-12)
        assert float(metrics["ATE RMSE [m] max"]) == pytest.approx(high, rel=1e-12)
        verdict = next(r for r in csv_rows("verdict") if r["best"] == column)
        assert float(verdict["median [m]"]) == pytest.approx(median, rel=1e-12)
        assert float(verdict["min [m]"]) == pytest.approx(low, rel=1e-12)
        # the table of runs holds every seed's value
        seeds = [r for r in csv_rows("room-seeds") if r["estimator"] == column]
        assert sorted(float(r["ATE RMSE [m]"]) for r in seeds) == pytest.approx(values)
    # dead reckoning ran once: its row says so instead of a spread
    header, rows = md_shown["room-metrics"]
    assert next(r for r in rows if r[0] == "deadreckoning")[header.index("seeds")] == (
        "deterministic"
    )


def test_provenance_block_and_publication_tables(fakes, tmp_path):
    results = run_room_grid(
        tmp_path, {"amplitude": 0.02}, {"amplitude": 0.5, "seed_gain": 0.2}, "clear"
    )
    write_report(results, tmp_path / "report", FAST)
    report = tmp_path / "report"
    md = (report / "report.md").read_text()
    html = (report / "index.html").read_text()
    tables = md_tables(md)
    assert {"verdict", "ate-rmse", "estimators", "room-metrics", "provenance"} <= set(tables)
    facts = dict(tables["provenance"][1])  # what -> value
    assert facts["omnislam version"] == omnislam.__version__
    source = Path(omnislam.__file__).resolve().parent.parent
    if (source / ".git").exists():
        head = subprocess.run(
            ["git", "-C", str(source), "rev-parse", "HEAD"], capture_output=True, text=True
        ).stdout.strip()
        assert facts["git commit"].split()[0] == head
    else:
        assert facts["git commit"] == "unknown"
    assert facts["command line"] == "omnislam report R"
    assert facts["seeds"] == "0, 1"
    assert "frames 60; images 0;" in facts["dataset room"]
    assert "(ground truth)" in facts["dataset room"]
    length = float(re.search(r"path length ([\d.]+) m", facts["dataset room"]).group(1))
    assert 15.0 < length < 2 * np.pi * 3.0  # the 6 m x 5 m ellipse of the room log
    assert facts["estimator tidy_odo"] == "tidy_odo; options: amplitude=0.02"
    assert facts["estimator rough_odo"] == "rough_odo; options: amplitude=0.5, seed_gain=0.2"
    assert facts["estimator deadreckoning"].endswith("options: defaults")
    assert f"{os.cpu_count()} cores" in facts["machine"] and "Python 3." in facts["machine"]
    assert "grid.yaml" in facts["grid"]
    for value in ("git commit", "machine", "seeds"):
        assert facts[value].replace("'", "&#x27;") in html
    for name, (_, rows) in tables.items():
        parsed = list(csv.reader(io.StringIO((report / "tables" / f"{name}.csv").read_text())))
        assert len(parsed) == len(rows) + 1, name
        for shown, written in zip(rows, parsed[1:], strict=True):
            assert shown[0] == written[0], name
            numbers = [float(t) for cell in written for t in NUMBER.findall(cell)]
            for token in (t for cell in shown for t in NUMBER.findall(cell)):
                assert any(abs(float(token) - n) <= tolerance(token) for n in numbers), (
                    name,
                    token,
                    written,
                )
        tex = (report / "tables" / f"{name}.tex").read_text()
        assert tex.index(r"\toprule") < tex.index(r"\midrule") < tex.index(r"\bottomrule")
        body = tex[tex.index(r"\toprule") : tex.index(r"\bottomrule")]
        assert body.count(r"\\") == len(rows) + 1
        assert "±" not in tex and not re.search(r"(?<!\\)[_%&#]", body.replace(" & ", " "))
        assert 'href="data:text/csv;charset=utf-8;base64,' in html
        assert f"tables/{name}.tex" in md
    assert r"tidy\_odo" in (report / "tables" / "verdict.tex").read_text()
    # the CSV keeps full precision where the table rounds
    row = next(csv.DictReader(io.StringIO((report / "tables" / "ate-rmse.csv").read_text())))
    rough = sorted(ate_by_column(results)["rough_odo"])
    assert float(row["rough_odo"]) == pytest.approx(rough[0], rel=1e-12)  # low median of two
    assert float(row["rough_odo max"]) == pytest.approx(rough[1], rel=1e-12)


def test_latex_escape_and_provenance_never_fail(tmp_path, monkeypatch):
    assert latex_escape("a_b & 5% #1 {x} ~ ^ \\ ± –") == (
        r"a\_b \& 5\% \#1 \{x\} \textasciitilde{} \textasciicircum{} \textbackslash{} "
        r"$\pm$ --"
    )
    assert provenance.package_commit(tmp_path) == "unknown"  # not a checkout
    (tmp_path / ".git").mkdir()  # looks like one, but git fails on it
    assert provenance.package_commit(tmp_path) == "unknown"

    def broken(*args, **kwargs):
        raise OSError("no git here")

    monkeypatch.setattr(subprocess, "run", broken)
    assert provenance.package_commit() == "unknown"
    assert provenance.cpu_model(tmp_path / "no-cpuinfo")  # falls back, never raises
    (tmp_path / "cpuinfo").write_text("processor\t: 0\nmodel name\t: Test CPU 9000\n")
    assert provenance.cpu_model(tmp_path / "cpuinfo") == "Test CPU 9000"


def test_the_report_shows_each_runs_association_counts(tmp_path):
    """Every association decision an estimator counts (estimator_info.json) is in the
    report, one row per run, for the estimators that count any (not dead reckoning): a small
    MR.CLAM folder with the barcodes hidden, so the back ends associate on their own."""
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    grid = {"name": "assoc",
            "datasets": [{"dataset": str(data), "label": "small",
                          "options": {"association": "unknown"}}],
            "estimators": ["deadreckoning", "graphslam", "ekfslam"], "seeds": [0]}
    results = tmp_path / "results"
    run_grid(parse_grid(json.dumps(grid), tmp_path / "grid.yaml"), results, SerialExecutor)
    write_report(results, tmp_path / "report", FAST)
    header, rows = md_tables((tmp_path / "report" / "report.md").read_text())["small-association"]
    assert header[:6] == ["estimator", "seed", "landmarks", "created", "associated", "ambiguous"]
    by_estimator = {row[0]: dict(zip(header, row, strict=True)) for row in rows}
    assert set(by_estimator) == {"graphslam", "ekfslam"}
    for name, row in by_estimator.items():
        (cell,) = (results / "cells").glob(f"*__{name}__*")
        info = json.loads((cell / "estimator_info.json").read_text())
        assert row["landmarks"] == str(info["landmarks"])
        created = info.get("landmarks_created", info.get("created"))
        associated = info.get("sightings_associated", info.get("associated"))
        assert row["created"] == str(created) and row["associated"] == str(associated)
        assert int(row["created"]) > 0 and int(row["associated"]) > 0  # landmarks seen again
