"""``omnislam._progress``: what a long command prints on stderr, on a terminal and off it."""

from __future__ import annotations

import io
import re
import time

import pytest

from omnislam import _progress
from omnislam._progress import Progress, Stages, format_duration, format_rate

#: what must never reach a log file: carriage returns and ANSI escape sequences
CONTROL = re.compile(r"[\r\x1b]")


class Capture(io.StringIO):
    """A stream that says whether it is a terminal."""

    def __init__(self, tty: bool) -> None:
        super().__init__()
        self._tty = tty

    def isatty(self) -> bool:
        return self._tty


@pytest.fixture(autouse=True)
def _every_line(monkeypatch):
    """Print every line at once (no first-line delay, no interval) unless a test says otherwise."""
    monkeypatch.setenv(_progress.ENABLE_VARIABLE, "1")
    monkeypatch.setenv(_progress.INTERVAL_VARIABLE, "0")


def test_durations_and_rates_read_as_a_person_would():
    assert format_duration(0) == "0:00"
    assert format_duration(75) == "1:15"
    assert format_duration(3725) == "1:02:05"
    assert format_duration(0.2) == "0:01"  # rounded up: an ETA never reads 0 too early
    assert format_rate(30, 2.0, "frame") == "15 frame/s"
    assert format_rate(1, 4.0, "img") == "4 s/img"
    assert format_rate(0, 1.0, "frame") == ""


def test_plain_lines_off_a_terminal_count_rate_eta_and_what_runs():
    out = Capture(tty=False)
    with Progress("run graphslam on lab40", 10, "frame", stream=out) as bar:
        for k in range(1, 6):
            time.sleep(0.01)
            bar.update(k, doing="running")
    text = out.getvalue()
    assert not CONTROL.search(text), repr(text)
    lines = text.splitlines()
    assert lines[-1].startswith("run graphslam on lab40: 5/10 frame (50%), ")
    assert "done in 0:0" in lines[-1]
    middle = [line for line in lines if "3/10 frame (30%)" in line]
    assert middle, lines
    assert re.search(r"[\d.]+ frame/s, ETA \d+:\d\d - running$", middle[0]), middle[0]


def test_a_terminal_gets_one_line_redrawn_in_place():
    out = Capture(tty=True)
    with Progress("frontend demo", 4, "img", stream=out) as bar:
        for _ in range(4):
            bar.advance()
    text = out.getvalue()
    assert text.count("\r") >= 2 and "\x1b[K" in text
    assert text.count("\n") == 1 and text.endswith("\n")  # the stage's last state stays
    assert "4/4 img (100%)" in text.rsplit("\r", 1)[-1]


def test_the_plain_interval_keeps_the_rate_of_lines_modest(monkeypatch):
    monkeypatch.setenv(_progress.INTERVAL_VARIABLE, "60")
    out = Capture(tty=False)
    monkeypatch.setattr(_progress, "FIRST_LINE_DELAY_S", 0.0)
    with Progress("synth lab40", 1000, "img", stream=out) as bar:
        for k in range(1000):
            bar.update(k + 1)
    lines = out.getvalue().splitlines()
    assert len(lines) == 2, lines  # the first, then the last; nothing between within a minute
    assert lines[0].startswith("synth lab40: 1/1000 img") and "done in" in lines[1]


def test_a_short_stage_prints_nothing(monkeypatch):
    monkeypatch.setenv(_progress.INTERVAL_VARIABLE, "10")
    out = Capture(tty=False)
    with Progress("run deadreckoning on room", 40, "frame", stream=out) as bar:
        for k in range(40):
            bar.update(k + 1)
    assert out.getvalue() == ""


def test_a_stage_that_reports_nothing_still_shows_it_is_alive():
    out = Capture(tty=False)
    with Progress("run graphslam-batch on lab40", stream=out) as bar:
        bar.update(doing="final estimate")
        time.sleep(1.5)  # the ticker prints while nobody calls update
    lines = out.getvalue().splitlines()
    assert any(re.fullmatch(r".*: final estimate \(0:0[1-2]\)", line) for line in lines), lines


def test_a_failed_stage_leaves_no_done_line():
    out = Capture(tty=False)
    with pytest.raises(RuntimeError), Progress("run x", 10, stream=out) as bar:
        bar.update(3)
        raise RuntimeError("boom")
    assert "done" not in out.getvalue()


def test_only_the_innermost_stage_prints():
    out = Capture(tty=False)
    outer = Progress("run graphslam on demo", stream=out)
    outer.update(doing="front end")
    with Progress("frontend demo", 3, "img", stream=out) as inner:
        for _ in range(3):
            inner.advance()
            outer.update(doing="front end")  # silent while the inner stage is open
    outer.close()
    lines = out.getvalue().splitlines()
    inner_lines = [i for i, line in enumerate(lines) if line.startswith("frontend demo")]
    outer_lines = [i for i, line in enumerate(lines) if line.startswith("run graphslam")]
    assert inner_lines and outer_lines
    assert not any(inner_lines[0] < i < inner_lines[-1] for i in outer_lines), lines


def test_silenced_progress_prints_nothing(monkeypatch):
    monkeypatch.setenv(_progress.ENABLE_VARIABLE, "0")
    out = Capture(tty=True)
    with Progress("anything", 3, stream=out) as bar:
        bar.update(3)
    assert out.getvalue() == ""


def test_stages_count_frames_where_a_stage_counts_and_time_elsewhere(capsys):
    with Stages("run ekfslam on room") as stages:
        stages("loading", 0, 0)
        for k in range(1, 4):
            stages("running", k, 3)
        stages("final estimate", 3, 3)
    err = capsys.readouterr().err
    assert not CONTROL.search(err)
    assert "run ekfslam on room: loading done in" in err
    assert "run ekfslam on room: 3/3 frame (100%)" in err
    assert "run ekfslam on room: final estimate done in" in err


def test_a_stage_dropped_by_an_exception_stops_printing():
    import gc

    out = Capture(tty=False)

    def stage_that_fails() -> None:
        bar = Progress("frontend demo", 59, "img", stream=out)
        bar.update(3)
        raise ValueError("a bad image")

    with pytest.raises(ValueError):
        stage_that_fails()
    gc.collect()
    time.sleep(0.3)
    printed = out.getvalue()
    time.sleep(1.5)  # a leaked ticker would print a line a second here
    assert out.getvalue() == printed
    with Progress("run x", 2, stream=out) as bar:  # and the next stage is the innermost
        bar.update(2)
    assert "run x: 2/2 frame (100%)" in out.getvalue()
