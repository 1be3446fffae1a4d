"""A full disk while writing a RUN_DIR, a report or a results folder: the previous output stays.

The disk fills up in a subprocess whose file-size limit (``RLIMIT_FSIZE``, SIGXFSZ ignored)
makes a write beyond ``limit`` bytes fail with EFBIG, as a full disk fails with ENOSPC; the
command must exit 2 with one line that says what could not be written and that the previous
output is left as it was, and every file of that output must be byte for byte what it was.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from room_log import write_room_log

from omnislam.cli import main

REPO = Path(__file__).resolve().parents[2]


def _contents(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*") if p.is_file()}


def _with_full_disk(limit_bytes: int, *argv: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """``omnislam ARGV`` in a subprocess that cannot write a file beyond ``limit_bytes``."""

    def limit() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    env = dict(os.environ, PYTHONPATH=str(REPO), OMNISLAM_CACHE=str(cwd / "cache"),
               PYTHONDONTWRITEBYTECODE="1")
    return subprocess.run([sys.executable, "-m", "omnislam", "--quiet", *argv], cwd=cwd, env=env,
                          preexec_fn=limit, capture_output=True, text=True, timeout=300)


def _assert_refused(result: subprocess.CompletedProcess[str], what: str) -> None:
    lines = result.stderr.strip().splitlines()
    assert result.returncode == 2, result.stderr
    assert len(lines) == 1, result.stderr
    assert "File too large" in lines[0], result.stderr
    assert f"the previous {what} is left as it was" in lines[0], result.stderr


@pytest.fixture
def room(tmp_path: Path) -> Path:
    return write_room_log(tmp_path / "room.log", frames=20)


def test_a_run_dir_replaced_on_a_full_disk_stays_as_it_was(room: Path, tmp_path: Path) -> None:
    out = tmp_path / "R"
    argv = ["run", str(room), "--estimator", "deadreckoning", "--out", str(out)]
    assert main(["--quiet", *argv]) == 0
    before = _contents(out)
    result = _with_full_disk(1000, *argv, "--overwrite", cwd=tmp_path)
    _assert_refused(result, "RUN_DIR")
    assert _contents(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["R", "room.log"]  # no staging left


def test_a_report_replaced_on_a_full_disk_stays_as_it_was(room: Path, tmp_path: Path) -> None:
    run, report = tmp_path / "R", tmp_path / "report"
    assert main(["--quiet", "run", str(room), "--estimator", "deadreckoning", "--out", str(run)]
                ) == 0
    assert main(["--quiet", "report", str(run), "--out", str(report), "--no-exports"]) == 0
    before = _contents(report)
    result = _with_full_disk(20_000, "report", str(run), "--out", str(report), "--no-exports",
                             "--overwrite", cwd=tmp_path)
    _assert_refused(result, "report")
    assert _contents(report) == before


def test_a_results_folder_resumed_on_a_full_disk_keeps_its_cells_and_summary(
    room: Path, tmp_path: Path
) -> None:
    """The new cell is written (small files), its summary is not: the previous summary stays
    (the folder's copy of the grid is the resumed grid, as on any resume)."""
    grid, results = tmp_path / "grid.yaml", tmp_path / "results"
    grid.write_text(f"datasets: [{room}]\nestimators: [deadreckoning]\nseeds: [0]\n")
    assert main(["--quiet", "compare", str(grid), "--out", str(results), "--workers", "0"]) == 0
    before = _contents(results)
    grid.write_text(f"datasets: [{room}]\nestimators: [deadreckoning]\nseeds: [0, 1]\n")
    result = _with_full_disk(3000, "compare", str(grid), "--out", str(results), "--workers", "0",
                             "--resume", cwd=tmp_path)
    _assert_refused(result, "results summary")
    after = _contents(results)
    assert {k: v for k, v in after.items() if k in before and k != "grid.yaml"} == {
        k: v for k, v in before.items() if k != "grid.yaml"
    }
    assert set(before) <= set(after)
