"""``omnislam compare`` / ``omnislam report`` end to end, and bad input to every command."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.cli import COMMANDS, main


@pytest.fixture(autouse=True)
def _commands(monkeypatch):
    """The commands are registered by the lead in COMMANDS; make sure they are here."""
    monkeypatch.setitem(COMMANDS, "compare", "compare")
    monkeypatch.setitem(COMMANDS, "report", "report")


def grid_file(tmp_path: Path, text: str | None = None) -> Path:
    write_room_log(tmp_path / "data" / "room.log", frames=40)
    path = tmp_path / "grid.yaml"
    path.write_text(
        text
        if text is not None
        else "datasets: [data/room.log]\nestimators: [deadreckoning]\nseeds: [0, 1]\n"
    )
    return path


def one_line_error(capsys, *needles):
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    for needle in needles:
        assert needle in err, err
    return err


def test_compare_then_report_then_rerun_reuses(tmp_path, capsys):
    grid = grid_file(tmp_path)
    out = tmp_path / "results"
    assert main(["compare", str(grid), "--out", str(out), "--workers", "0"]) == 0
    assert "1 computed" in capsys.readouterr().out  # dead reckoning: one run stands for both seeds
    assert main(["compare", str(grid), "--out", str(out), "--workers", "2"]) == 2
    one_line_error(capsys, "results", "--resume", "--overwrite")  # the one overwrite rule
    assert main(["compare", str(grid), "--out", str(out), "--workers", "2", "--resume"]) == 0
    assert "1 reused" in capsys.readouterr().out
    report = tmp_path / "reports" / "room"
    assert main(["report", str(out), "--out", str(report)]) == 0
    page = (report / "index.html").read_text()
    figures = re.findall(r"<svg\b.*?</svg>", page, flags=re.S)
    assert len(figures) >= 4 and all("<text" in svg for svg in figures)
    rows = json.loads((out / "results.json").read_text())["cells"]
    assert [r["status"] for r in rows] == ["reused"]


def test_compare_on_a_local_dask_cluster(tmp_path, capsys):
    pytest.importorskip("distributed")
    grid = grid_file(tmp_path)
    out = tmp_path / "results"
    assert (
        main(["compare", str(grid), "--out", str(out), "--scheduler", "local", "--workers", "1"])
        == 0
    )
    assert "1 computed" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ("datasets: [data/room.log\nestimators: [x]\n", ["grid.yaml", "not valid YAML"]),
        ("- just a list\n", ["grid.yaml", "expected a mapping"]),
        (
            "datasets: [data/room.log]\nestimators: [kalman]\n",
            ["grid.yaml", "unknown estimator 'kalman'"],
        ),
        (
            "datasets: [data/nowhere.log]\nestimators: [deadreckoning]\n",
            ["grid.yaml", "nowhere.log"],
        ),
        ("datasets: [data/room.log]\nestimators: [deadreckoning]\nseeds: [a]\n", ["seeds"]),
        ("datasets: [data/room.log]\nestimators: [deadreckoning]\ncolour: red\n", ["unknown keys"]),
    ],
)
def test_compare_bad_grid_exits_2_and_writes_nothing(tmp_path, capsys, text, needles):
    grid = grid_file(tmp_path, text)
    out = tmp_path / "results"
    assert main(["compare", str(grid), "--out", str(out)]) == 2
    one_line_error(capsys, *needles)
    assert not out.exists()


def test_compare_missing_grid_file_and_foreign_out_folder(tmp_path, capsys):
    assert main(["compare", str(tmp_path / "none.yaml"), "--out", str(tmp_path / "r")]) == 2
    one_line_error(capsys, "none.yaml", "cannot read")
    assert not (tmp_path / "r").exists()
    grid = grid_file(tmp_path)
    foreign = tmp_path / "precious"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("x")
    assert main(["compare", str(grid), "--out", str(foreign)]) == 2
    one_line_error(capsys, "precious", "refusing")
    assert sorted(p.name for p in foreign.iterdir()) == ["notes.txt"]


def test_compare_reports_failed_cells_with_exit_1(tmp_path, capsys):
    grid = grid_file(
        tmp_path,
        "datasets: [data/room.log]\n"
        "estimators: [deadreckoning, ukf]\n",  # ukf finds no map: known only at run time
    )
    assert main(["compare", str(grid), "--out", str(tmp_path / "r"), "--workers", "0"]) == 1
    err = capsys.readouterr().err
    assert "cell room__ukf__s0 failed" in err and "room__deadreckoning__s0" not in err


def test_compare_refuses_a_bad_option_before_any_cell_runs(tmp_path, capsys):
    grid = grid_file(
        tmp_path,
        "datasets: [data/room.log]\n"
        "estimators:\n  - {estimator: deadreckoning, options: {speed: 2}}\n",
    )
    assert main(["compare", str(grid), "--out", str(tmp_path / "r"), "--workers", "0"]) == 2
    one_line_error(capsys, "room__deadreckoning__s0", "takes no options")
    assert not (tmp_path / "r").exists()


def test_report_bad_input_exits_2_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["report", str(tmp_path / "missing"), "--out", str(out)]) == 2
    one_line_error(capsys, "missing", "no such folder")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["report", str(empty), "--out", str(out)]) == 2
    one_line_error(capsys, "empty", "not a results folder")
    # a RUN_DIR whose trajectory is gone
    run = tmp_path / "run"
    log = write_room_log(tmp_path / "data" / "room.log", frames=20)
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    (run / "trajectory.tum").unlink()
    capsys.readouterr()
    assert main(["report", str(run), "--out", str(out)]) == 2
    one_line_error(capsys, "trajectory.tum")
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_evaluate_bad_input_exits_2(tmp_path, capsys):
    assert main(["evaluate", str(tmp_path / "missing")]) == 2
    one_line_error(capsys, "missing")
    run = tmp_path / "run"
    log = write_room_log(tmp_path / "data" / "room.log", frames=20)
    assert main(["run", str(log), "--estimator", "deadreckoning", "--out", str(run)]) == 0
    (run / "trajectory.tum").unlink()
    capsys.readouterr()
    assert main(["evaluate", str(run)]) == 2
    one_line_error(capsys, "trajectory.tum")
    assert not (run / "metrics.json").exists()


def test_run_bad_input_exits_2(tmp_path, capsys):
    out = tmp_path / "run"
    assert (
        main(["run", str(tmp_path / "nowhere"), "--estimator", "deadreckoning", "--out", str(out)])
        == 2
    )
    one_line_error(capsys, "nowhere")
    assert not out.exists()
