"""Progress of the long commands as a user sees it: on stderr, plain lines off a terminal (no
escape codes), one redrawn line on a terminal, frames from inside the runs of a grid."""

from __future__ import annotations

import os
import pty
import re
import subprocess
import sys
from pathlib import Path

import pytest
from small_mrclam import write_small_mrclam

from omnislam.harness import channel
from omnislam.harness.channel import ProgressChannel

REPO = Path(__file__).resolve().parents[2]
CONTROL = re.compile(r"[\r\x1b]")


def _env(**extra: str) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMNISLAM_PROGRESS_INTERVAL": "0", **extra}
    env.pop("OMNISLAM_PROGRESS", None)
    env.pop("DASK_LOGGING__DISTRIBUTED", None)
    return env


def _frames(data: Path) -> int:
    """Frames of the small MR.CLAM run: the start, every stamp with a sighting and the frames
    that fill longer gaps (``datasets.mrclam.MAX_STEP_S``), as the loader makes them."""
    from omnislam.datasets.mrclam import load_mrclam

    return len(load_mrclam(data, 1))


def _omnislam(*args: str, **extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "omnislam", *args],
        capture_output=True,
        text=True,
        env=_env(**extra),
        check=True,
    )


def test_run_prints_frames_rate_and_eta_as_plain_lines_off_a_terminal(tmp_path):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    result = _omnislam("run", str(data), "--estimator", "ekfslam", "--out", str(tmp_path / "r"))
    err = result.stderr
    assert not CONTROL.search(err), repr(err)
    lines = [x for x in err.splitlines() if x.startswith("run ekfslam on MRCLAM_Small: ")]
    frames = _frames(data)
    counted = [x for x in lines if re.search(rf": \d+/{frames} frame \(\d+%\)", x)]
    assert len(counted) >= 2, err
    assert any("done in" in x for x in counted), err
    assert "-> " in result.stdout  # the result line is on stdout, progress is not


def test_quiet_silences_progress(tmp_path):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    argv = ["--quiet", "run", str(data), "--estimator", "ekfslam", "--out", str(tmp_path / "r")]
    result = _omnislam(*argv)
    assert "frame" not in result.stderr


def test_a_terminal_gets_one_line_redrawn_in_place(tmp_path):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    leader, follower = pty.openpty()
    try:
        process = subprocess.Popen(
            [sys.executable, "-m", "omnislam", "run", str(data), "--estimator", "ekfslam",
             "--out", str(tmp_path / "r")],
            stdout=subprocess.DEVNULL,
            stderr=follower,
            env=_env(),
        )
        os.close(follower)
        chunks = []
        while True:
            try:
                chunk = os.read(leader, 4096)
            except OSError:  # the child closed the terminal
                break
            if not chunk:
                break
            chunks.append(chunk)
        assert process.wait(timeout=120) == 0
    finally:
        os.close(leader)
    text = b"".join(chunks).decode(errors="replace")
    assert "\r" in text and "\x1b[K" in text
    n = _frames(data)
    assert re.search(rf"run ekfslam on MRCLAM_Small: {n}/{n} frame \(100%\).*done in", text)


def test_compare_shows_the_frames_the_workers_step(tmp_path):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    grid = tmp_path / "grid.yaml"
    grid.write_text(f"datasets: [{data.name}]\nestimators: [deadreckoning, ekfslam]\n")
    result = _omnislam("compare", str(grid), "--out", str(tmp_path / "results"), "--workers", "1")
    err = result.stderr
    assert not CONTROL.search(err), repr(err)
    lines = [x for x in err.splitlines() if x.startswith("compare (1 local): ")]
    # what a worker process is doing, sent from inside its run
    assert any(re.search(rf"- ekfslam \d+/{_frames(data)}", x) for x in lines), err
    assert any(re.search(r"- deadreckoning loading", x) for x in lines), err
    n = 2 * _frames(data)  # two cells
    assert re.search(rf"2/2 cells, {n}/{n} frame \(100%\).*done in", lines[-1]), lines[-1]


@pytest.mark.slow
@pytest.mark.parametrize("workers", ["0", "2"])
def test_compare_prints_each_warning_once_after_its_progress(tmp_path, workers):
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    measurements = data / "Robot1_Measurement.dat"
    measurements.write_text(measurements.read_text() + "30.0 99 1.0 0.1\n")  # no such barcode
    grid = tmp_path / "grid.yaml"
    grid.write_text(f"datasets: [{data.name}]\nestimators: [deadreckoning, fastslam1]\n")
    grid.write_text(grid.read_text() + "seeds: [0, 1]\n")  # dead reckoning runs once
    out = tmp_path / "results"
    result = _omnislam("compare", str(grid), "--out", str(out), "--workers", workers)
    lines = result.stderr.splitlines()
    # the dataset is loaded by the grid's check and by each of its 3 cells: one line
    warned = [i for i, x in enumerate(lines) if "sightings with unknown barcodes dropped" in x]
    assert len(warned) == 1, result.stderr
    assert lines[warned[0]].startswith("WARNING omnislam.datasets.mrclam: ")
    progress = [i for i, x in enumerate(lines) if x.startswith("compare (")]
    assert progress and max(progress) < warned[0], result.stderr  # after the progress lines
    assert "3 computed" in result.stdout


@pytest.mark.slow
def test_report_ends_with_every_dataset_done(tmp_path):
    """The report's last progress line counts every dataset (its exports come after the
    figures and once printed "0/1 dataset ... done")."""
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    grid = tmp_path / "grid.yaml"
    grid.write_text(f"datasets: [{data.name}]\nestimators: [deadreckoning]\n")
    _omnislam("compare", str(grid), "--out", str(tmp_path / "results"), "--workers", "1")
    result = _omnislam("report", str(tmp_path / "results"), "--out", str(tmp_path / "report"))
    lines = [x for x in result.stderr.splitlines() if x.startswith("report report: ")]
    assert lines and not CONTROL.search(result.stderr), result.stderr
    assert re.search(r"1/1 dataset \(100%\).*done in", lines[-1]), lines[-1]


def _report(address: str, key: bytes, frames: int) -> None:
    """A worker process: report every frame of a run through the channel."""
    channel.SEND_INTERVAL_S = 0.0
    reporter = channel.StepReporter(address, key, "cell-a")
    reporter("loading", 0, 0)
    for done in range(frames + 1):
        reporter("running", done, frames)


def test_the_channel_carries_a_workers_frames_in_order():
    import multiprocessing
    import time

    with ProgressChannel() as progress:
        reporter = progress.reporter("cell-a")
        worker = multiprocessing.get_context("spawn").Process(
            target=_report, args=(reporter.address, reporter.authkey, 25)
        )
        worker.start()
        worker.join(timeout=120)
        assert worker.exitcode == 0
        messages = []
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and len(messages) < 27:
            messages += progress.drain()
            time.sleep(0.02)
    assert [(m.stage, m.done) for m in messages] == [("loading", 0)] + [
        ("running", k) for k in range(26)
    ]
    assert {m.key for m in messages} == {"cell-a"} and messages[-1].total == 25


def test_a_reporter_that_cannot_reach_its_channel_stays_silent():
    reporter = channel.StepReporter("/nonexistent/socket", b"key", "cell")
    for done in range(3):
        reporter("running", done, 3)  # no error: progress never fails a run


@pytest.mark.slow
def test_dask_is_quiet_unless_verbose(tmp_path):
    pytest.importorskip("distributed")
    data = write_small_mrclam(tmp_path / "MRCLAM_Small")
    grid = tmp_path / "grid.yaml"
    grid.write_text(f"datasets: [{data.name}]\nestimators: [deadreckoning]\n")
    argv = ["compare", str(grid), "--scheduler", "local", "--workers", "1"]
    quiet = _omnislam(*argv, "--out", str(tmp_path / "a"))
    assert " INFO " not in quiet.stderr and "distributed." not in quiet.stderr, quiet.stderr
    assert re.search(r"compare \(Dask at .*\): .*deadreckoning", quiet.stderr), quiet.stderr
    verbose = _omnislam("-v", *argv, "--out", str(tmp_path / "b"))
    assert "INFO" in verbose.stderr
