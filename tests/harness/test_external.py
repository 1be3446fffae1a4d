"""Another system's results in a grid: ``estimator: external`` cells (``harness.external``).

The other system here is graphslam itself, run outside the grid (``execute_run`` and
``write_run_dir``, as ``omnislam run`` does): given as an external cell, its trajectory and map
must score exactly as the graphslam cell of the same grid and tie with it in the report's
verdict, drawn in its own colour, its provenance saying it was not run here.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.datasets.trajectory_io import read_tum, write_kitti
from omnislam.errors import ConfigError
from omnislam.harness.execute import RunSpec, execute_run
from omnislam.harness.grid import parse_grid
from omnislam.harness.rundir import read_run_config, write_run_dir
from omnislam.harness.runner import CellStatus, SerialExecutor, run_grid
from omnislam.report import palette
from omnislam.report.comparison import write_report
from omnislam.report.options import ReportOptions

EXTERNAL_CELL = {
    "estimator": "external",
    "label": "mysys",
    "files": "outside/{dataset}/{seed}/trajectory.tum",
    "landmarks": "outside/{dataset}/{seed}/landmarks.csv",
}


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The room log and a graphslam run on it made outside any grid (seed 0)."""
    pytest.importorskip("gtsam")
    tmp = tmp_path_factory.mktemp("external")
    write_room_log(tmp / "data" / "room.log", frames=40)
    record = execute_run(RunSpec(str(tmp / "data" / "room.log"), "graphslam", seed=0))
    write_run_dir(tmp / "outside" / "room" / "0", record)
    return tmp


def _grid(folder: Path, *estimators: object) -> str:
    return json.dumps({"datasets": ["data/room.log"], "estimators": list(estimators)})


@pytest.fixture(scope="module")
def report(folder: Path) -> Path:
    grid = parse_grid(_grid(folder, "deadreckoning", "graphslam", EXTERNAL_CELL), folder / "g.yaml")
    result = run_grid(grid, folder / "results", SerialExecutor)
    assert all(o.status is CellStatus.COMPUTED for o in result.outcomes), result.outcomes
    write_report(folder / "results", folder / "report", ReportOptions(exports=False))
    return folder / "report"


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def test_an_external_graphslam_ranks_equal_to_the_graphslam_cell(report: Path):
    ate = _rows(report / "tables" / "ate-rmse.csv")[0]
    assert float(ate["mysys"]) == pytest.approx(float(ate["graphslam"]), abs=1e-12)
    assert float(ate["mysys"]) < float(ate["deadreckoning"])
    # the other system's results are set beside the runs of the input graphslam read, as a
    # family of their own, no distance behind it
    verdict = _rows(report / "tables" / "verdict.csv")
    assert {row["input"] for row in verdict} == {"range-bearing-2d (front end)"}
    assert {(row["best"], row["family"]) for row in verdict} == {
        ("graphslam", "factor graph"), ("mysys", "another system")}
    assert all(float(row["behind the best [m]"]) == pytest.approx(0.0, abs=1e-12)
               for row in verdict)
    assert "graphslam and mysys tie" in (report / "report.md").read_text()
    metrics = {r["estimator"]: r for r in _rows(report / "tables" / "room-metrics.csv")}
    for key in ("RPE 2 m trans RMSE [m]", "ATE max [m]"):
        assert float(metrics["mysys"][key]) == pytest.approx(float(metrics["graphslam"][key]))
    key = "landmarks matched / estimated"  # the map read too
    assert metrics["mysys"][key] == metrics["graphslam"][key]
    assert not metrics["mysys"][key].endswith("/ 0")
    cost = {r["estimator"]: r for r in _rows(report / "tables" / "room-cost.csv")}
    assert "graphslam" in cost and cost.get("mysys", {}).get("total [s]", "") == ""  # not run here


def test_it_is_drawn_in_its_colour_and_says_it_was_not_run_here(report: Path, folder: Path):
    colour = palette.colours(["deadreckoning", "graphslam", "mysys"])["mysys"]
    for figure in ("ate-seeds", "trajectories"):
        assert colour in (report / f"room-{figure}.svg").read_text(), figure
    provenance = {r["what"]: r["value"] for r in _rows(report / "tables" / "provenance.csv")}
    trajectory = folder / "outside" / "room" / "0" / "trajectory.tum"
    assert provenance["estimator mysys"].startswith("not run here: results of another system")
    assert str(trajectory) in provenance["estimator mysys"]
    config = read_run_config(folder / "results" / "cells" / "room__mysys__s0")
    assert config.estimator == "external" and config.external is not None


def test_a_kitti_trajectory_takes_the_frame_stamps(folder: Path, report: Path):
    """The same trajectory as KITTI (no stamps: one pose per frame) scores the same."""
    outside = folder / "outside" / "room" / "0"
    write_kitti(folder / "kitti" / "room-0.txt", read_tum(outside / "trajectory.tum"))
    kitti = {"estimator": "external", "label": "mysys-kitti", "files": "kitti/{dataset}-{seed}.txt"}
    grid = parse_grid(_grid(folder, "graphslam", kitti), folder / "g2.yaml")
    result = run_grid(grid, folder / "results-kitti", SerialExecutor)
    ate = {o.cell.estimator_label: o.metrics.ate.rmse_m for o in result.outcomes}  # type: ignore[union-attr]
    assert ate["mysys-kitti"] == pytest.approx(ate["graphslam"], abs=1e-9)
    again = run_grid(grid, folder / "results-kitti", SerialExecutor)
    statuses = {o.cell.estimator_label: o.status for o in again.outcomes}
    assert statuses == {"graphslam": CellStatus.REUSED, "mysys-kitti": CellStatus.COMPUTED}


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"estimator": "external", "label": "x"}, "'files' must be a file pattern"),
        ({**EXTERNAL_CELL, "files": "outside/{run}.tum"}, "unknown placeholders ['run']"),
        ({**EXTERNAL_CELL, "files": "outside/{dataset"}, "'files': malformed pattern"),
        ({**EXTERNAL_CELL, "files": "nowhere/{seed}.tum"}, "nowhere/0.tum not found (dataset room"),
        ({**EXTERNAL_CELL, "landmarks": "none/{seed}.csv"}, "'landmarks':"),
        ({**EXTERNAL_CELL, "format": "csv"}, "'format' must be one of auto, tum, kitti"),
        ({**EXTERNAL_CELL, "options": {"a": 1}}, "an external estimator takes no 'options'"),
        ({**EXTERNAL_CELL, "true_landmark_ids": "yes"}, "'true_landmark_ids' must be true"),
        ({"estimator": "graphslam", "files": "x.tum"}, "['files'] apply to 'estimator: external'"),
    ],
)
def test_bad_external_entries_are_one_line_naming_the_file_and_key(folder: Path, entry, message):
    with pytest.raises(ConfigError) as error:
        parse_grid(_grid(folder, entry), folder / "bad.yaml")
    text = str(error.value)
    assert "\n" not in text
    assert text.startswith(f"{folder / 'bad.yaml'}: estimators[0]: ")
    assert message in text


def test_a_malformed_trajectory_fails_its_cell_naming_the_file_and_line(folder: Path):
    bad = folder / "broken" / "room" / "0.tum"
    bad.parent.mkdir(parents=True)
    bad.write_text("0 0 0 0 0 0 0 1\n1 0 0 0 0 0\n")
    entry = {"estimator": "external", "label": "broken", "files": "broken/{dataset}/{seed}.tum"}
    grid = parse_grid(_grid(folder, entry), folder / "g3.yaml")
    outcome = run_grid(grid, folder / "results-broken", SerialExecutor).outcomes[0]
    assert outcome.status is CellStatus.FAILED
    assert str(bad) in str(outcome.error) and "line 2: expected 8 values" in str(outcome.error)
